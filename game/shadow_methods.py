"""Which shadow maps exist, what each holds, and which must be re-rendered this frame.

``clumped`` is the seed's method: one cached map per clump of statics, one map per character
re-rendered every frame, all in one depth texture array. ``single`` is the baseline: one map
fitted to every caster, re-rendered every frame. Floors are never drawn into any map.

A method only plans; the Renderer owns the GL objects and draws what the plan lists.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import trimesh

from . import clumping, transforms
from .geometry import PackedGeometry
from .map_grid import octahedral_encode
from .scene import Light
from .shadow_fit import MapFit, fit_directional, fit_perspective, outside_cone

# KIND_CASCADE: keep in sync with shaders/shadow.glsl (the finest cascade holding a fragment wins).
KIND_CLUMP, KIND_CHARACTER, KIND_ALL, KIND_CASCADE = 0, 1, 2, 3
METHODS = ("clumped", "single", "static-dynamic", "csm")
CLUMPINGS = clumping.STRATEGIES

# Defaults chosen so the accuracy bar of tests/test_accuracy.py holds without per-scene tuning.
TEXELS_PER_METRE = 64.0        # clump maps' texel-density target
CLUMP_RESOLUTION = 1024        # texels per side of a clump map (and of the array's layers)
CHARACTER_RESOLUTION = 512     # texels per side a character's map uses of its layer
SINGLE_RESOLUTION = 4096       # the baseline's one map
NORMAL_BIAS_TEXELS = 1.0       # offset along the normal, times sin(angle to the light)
DEPTH_BIAS_TEXELS = 1.0        # offset towards the light
SLOPE_BIAS_TEXELS = 1.0        # offset towards the light, times tan(angle to the light)
MAX_SLOPE = 8.0                # cap on that tan, for grazing light
SHADOW_BUDGET_MIB = 512        # depth-array memory the clumped method may use
CASCADES = 4                   # csm: cascades (Bevy, Godot and Filament default to 4)
CASCADE_LAMBDA = 0.75          # csm: practical split blend, 1 logarithmic, 0 uniform
CASCADE_RESOLUTION = 2048      # csm: texels per side of each cascade


@dataclass
class ShadowSettings:
    """Everything a user can change about the hard shadows (CLI flags, later the overlay)."""

    method: str = "clumped"
    clumping: str = "light"
    clump_count: int | None = None
    texels_per_metre: float = TEXELS_PER_METRE
    clump_resolution: int = CLUMP_RESOLUTION
    character_resolution: int = CHARACTER_RESOLUTION
    single_resolution: int = SINGLE_RESOLUTION
    normal_bias: float = NORMAL_BIAS_TEXELS
    depth_bias: float = DEPTH_BIAS_TEXELS
    slope_bias: float = SLOPE_BIAS_TEXELS
    max_slope: float = MAX_SLOPE
    pcf: bool = False
    grid: str = "auto"
    budget_mib: float = SHADOW_BUDGET_MIB
    cascades: int = CASCADES
    cascade_lambda: float = CASCADE_LAMBDA
    cascade_resolution: int = CASCADE_RESOLUTION


@dataclass
class MapRecord:
    """One shadow map: its projection, its layer, and the objects drawn into it."""

    name: str
    kind: int
    fit: MapFit
    layer: int
    viewport: int          # texels per side used, from the layer's corner
    objects: list[int]     # global object indices
    # Directional light: light-space rectangles of the casters drawn into the map. Much tighter
    # than the map's own rectangle when a clump is spread out; the map grid lists a map for a
    # cell only where one of these (grown by the bias reach) overlaps it.
    cover: np.ndarray | None = None


@dataclass
class ShadowPlan:
    resolution: int                  # texels per side of the array's layers
    maps: list[MapRecord]            # every map the shading pass may sample
    render_static: list[int] = field(default_factory=list)   # indices into maps
    render_dynamic: list[int] = field(default_factory=list)
    static_order: list[int] | None = None  # statics in clump order, for the index buffer


def _footprint(light: Light, statics: list[np.ndarray]):
    """Light-space footprint function and units-per-metre scale for clumping."""
    if light.kind == "directional":
        return clumping.directional_footprint(transforms.light_rotation(light.direction)), 1.0
    eye = np.asarray(light.position, float)
    distances = [np.linalg.norm(p.mean(axis=0) - eye) for p in statics] or [1.0]
    typical = max(float(np.median(distances)), 1e-6)
    if light.kind == "spot":
        view = transforms.look_at(eye, eye + light.direction)

        def spot(points: np.ndarray) -> np.ndarray:
            v = transforms.transform_points(view, points)
            depth = np.maximum(-v[:, 2], 1e-6 * typical)
            return v[:, :2] / depth[:, None]

        return spot, 1.0 / typical

    def point(points: np.ndarray) -> np.ndarray:
        return octahedral_encode(np.asarray(points, float) - eye)

    # An octahedral unit spans about pi/2 radians.
    return point, 1.0 / (typical * math.pi / 2)


class ClumpedShadows:
    """The multi-map method: cached clump maps plus per-character maps in one array.

    The number of clumps follows the texel-density target, within the layers that the memory
    budget and the GL limits allow; when the target needs more, the clumps grow (and their
    texel density falls) and ``notes`` says so.
    """

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int):
        self.geom = geom
        self.settings = settings
        self.light = light
        layer_bytes = 4 * settings.clump_resolution ** 2
        budget_layers = int(settings.budget_mib * 2**20 // layer_bytes)
        self.max_clumps = max(1, min(budget_layers, max_layers) - geom.n_characters)
        self.notes: list[str] = []
        self.static_maps: list[MapRecord] = []
        self.clumps: list[clumping.Clump] = []
        self._static_dirty = True
        self.set_light(light)

    @property
    def layers(self) -> int:
        return max(1, len(self.static_maps) + self.geom.n_characters)

    @property
    def resolution(self) -> int:
        return self.settings.clump_resolution

    def set_light(self, light: Light) -> None:
        """A new light invalidates every clump map (and light-space clumps themselves)."""
        self.light = light
        self._light_rot = (transforms.light_rotation(light.direction)
                           if light.kind == "directional" else None)
        self._build_static()

    def invalidate_statics(self) -> None:
        """Static geometry changed: re-clump and re-render every clump map."""
        self._build_static()

    def _fit(self, points: np.ndarray, resolution: int, radius: float | None = None
             ) -> MapFit | None:
        light = self.light
        if light.kind == "directional":
            return fit_directional(points, self._light_rot, resolution, radius)
        if light.kind == "spot" and outside_cone(points, light.position, light.direction,
                                                 light.cone):
            return None
        return fit_perspective(points, light.position, resolution)

    def _build_static(self) -> None:
        s = self.settings
        points = self.geom.static_points
        footprint, per_metre = _footprint(self.light, points)
        max_extent = clumping.max_extent_for_density(s.clump_resolution, s.texels_per_metre)
        count = s.clump_count
        if count is not None and count > self.max_clumps:
            self.notes.append(f"{count} clumps asked, {self.max_clumps} fit the layer budget")
            count = self.max_clumps
        self.clumps = clumping.make_clumps(points, footprint, s.clumping, max_extent * per_metre,
                                           count)
        if len(self.clumps) > self.max_clumps:
            self.notes.append(
                f"{len(self.clumps)} clumps would meet {s.texels_per_metre:g} texels/m; "
                f"{self.max_clumps} fit the {s.budget_mib:g} MiB budget, so texels are coarser")
            self.clumps = clumping.make_clumps(points, footprint, s.clumping, 0.0,
                                               self.max_clumps)
        rects = (clumping.object_summaries(points, footprint)[0]
                 if self.light.kind == "directional" and points else None)
        self.static_order = [m for c in self.clumps for m in c.members]
        self.static_maps = []
        for clump in self.clumps:
            fit = self._fit(np.concatenate([points[i] for i in clump.members]),
                            s.clump_resolution)
            if fit is None:
                continue
            self.static_maps.append(MapRecord(
                name=f"clump_{len(self.static_maps)}", kind=KIND_CLUMP, fit=fit,
                layer=len(self.static_maps), viewport=s.clump_resolution,
                objects=[self.geom.static_object(i) for i in clump.members],
                cover=None if rects is None else rects[list(clump.members)]))
        self._static_dirty = True

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        """The maps for this frame; ``models`` are the characters' (n, 4, 4) matrices.

        ``view`` (the camera's renderer.View) is unused here; view-dependent methods (csm)
        need it.
        """
        s = self.settings
        maps = list(self.static_maps)
        render_static = list(range(len(maps))) if self._static_dirty else []
        render_dynamic = []
        resolution = s.clump_resolution
        char_res = min(s.character_resolution, resolution)
        for i in range(self.geom.n_characters):
            points = transforms.transform_points(models[i], self.geom.character_points[i])
            fit = self._fit(points, char_res, float(self.geom.character_radius[i]))
            if fit is None:
                continue
            cover = None
            if self.light.kind == "directional":
                xy = points @ self._light_rot[:2].T
                cover = np.concatenate([xy.min(axis=0), xy.max(axis=0)])[None]
            render_dynamic.append(len(maps))
            maps.append(MapRecord(name=f"character_{i}", kind=KIND_CHARACTER, fit=fit,
                                  layer=len(self.static_maps) + i, viewport=char_res,
                                  objects=[self.geom.character_object(i)], cover=cover))
        self._static_dirty = False
        return ShadowPlan(resolution=resolution, maps=maps,
                          render_static=render_static, render_dynamic=render_dynamic,
                          static_order=self.static_order)

    def mark_rendered_lost(self) -> None:
        """The array was re-created (resized): every cached layer must be drawn again."""
        self._static_dirty = True


class SingleShadows:
    """The baseline: one map over every caster, all re-rendered every frame."""

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings):
        self.geom = geom
        self.settings = settings
        self.notes: list[str] = []
        self.set_light(light)

    @property
    def layers(self) -> int:
        return 1

    @property
    def resolution(self) -> int:
        return self.settings.single_resolution

    def set_light(self, light: Light) -> None:
        """Keep only the statics' extreme points for this light; refitting is then cheap."""
        self.light = light
        points = (np.concatenate(self.geom.static_points) if self.geom.static_points
                  else np.zeros((0, 3)))
        self._light_rot = (transforms.light_rotation(light.direction)
                           if light.kind == "directional" else None)
        if light.kind == "directional" and len(points):
            q = points @ self._light_rot.T
            keep = np.unique(np.concatenate([q.argmin(axis=0), q.argmax(axis=0)]))
            points = points[keep]
        elif len(points):
            # Perspective fits need every direction; the vertices of the convex hull suffice.
            points = trimesh.convex.hull_points(points) if len(points) > 4 else points
        self._static_points = points

    def invalidate_statics(self) -> None:
        self.set_light(self.light)

    def mark_rendered_lost(self) -> None:
        pass

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        res = self.settings.single_resolution
        parts = [self._static_points] + [
            transforms.transform_points(models[i], self.geom.character_points[i])
            for i in range(self.geom.n_characters)]
        points = np.concatenate(parts)
        objects = ([self.geom.static_object(i) for i in range(self.geom.n_statics)]
                   + [self.geom.character_object(i) for i in range(self.geom.n_characters)])
        maps, render = [], []
        if len(points):
            light = self.light
            if light.kind == "directional":
                fit = fit_directional(points, self._light_rot, res)
            else:
                fit = fit_perspective(points, light.position, res)
            if fit is not None:
                maps.append(MapRecord("single", KIND_ALL, fit, 0, res, objects))
                render = [0]
        return ShadowPlan(resolution=res, maps=maps, render_dynamic=render)


def create(geom: PackedGeometry, light: Light, settings: ShadowSettings, max_layers: int):
    """The planner for ``settings.method``; ``max_layers`` is what the GL allows."""
    if settings.method == "clumped":
        return ClumpedShadows(geom, light, settings, max_layers)
    if settings.method == "single":
        return SingleShadows(geom, light, settings)
    if settings.method in ("static-dynamic", "csm"):
        from . import baselines  # the baselines build on this module's records

        if settings.method == "csm":
            return baselines.CascadedShadows(geom, light, settings)
        return baselines.StaticDynamicShadows(geom, light, settings)
    raise ValueError(f"unknown shadow method {settings.method!r}; valid: {', '.join(METHODS)}")
