"""The raster soft-shadow methods: depth maps from points of the linear light, looked up for
every G-buffer pixel; the same visibility image as the tracer's methods.

:class:`RasterSoft` is the raster twin of :class:`~game.soft.tracer.SoftTracer`: the same
``trace`` call, the same :class:`~game.soft.results.TraceResult`. Per frame it

1. plans the maps (game/soft/map_frusta.py) around the G-buffer's receivers;
2. draws what changed (game/soft/light_maps.py): the statics' maps only when the frusta moved,
   the walkers' maps always;
3. runs the method's lookup, one full-screen pass over the G-buffer (shaders/segment_maps.frag,
   shaders/pcss.frag) into an R32F target, and reads it back.

It owns the maps (one :class:`LightMaps` per count and resolution), the lookup programs, two
samplers (a bilinear depth compare, and plain depth for pcss's blocker search) and the target,
and releases them all in :meth:`RasterSoft.release`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import moderngl
import numpy as np

from game import transforms
from game.gpu import blocks, resources
from game.gpu.fullscreen import fullscreen_pass
from game.gpu.timing import PassTimer
from game.scene import Scene
from game.scene.geometry import PackedGeometry
from game.soft.grid import scene_bounds
from game.soft.light_maps import LightMaps
from game.soft.map_frusta import (
    SNAP_CELLS,
    box_corners,
    plan,
    receiver_cells,
    segment_points,
)
from game.soft.methods import LIMITS, RASTER_METHODS, TraceSettings
from game.soft.results import BYTE_COUNTERS, COUNTERS, TraceResult
from game.soft.tracer import TEXTURE_UNITS


@dataclass(frozen=True)
class MapBias:
    """How far a receiver's depth test leans toward lit, in texels of the map at the receiver:
    a normal offset, a constant and a slope-scaled bias, as the hard maps have
    (``--normal-bias`` and friends), with the tangent of the slope capped at ``max_slope``.
    Half the hard maps' constant and slope bias: the lookups compare bilinearly, which hides the
    acne a smaller bias lets through, and the light leaking beside contacts that a larger one
    makes was the raster methods' largest error (docs/design/raster-soft.md)."""

    normal: float = 0.25
    depth: float = 0.5
    slope: float = 0.5
    max_slope: float = 8.0


@dataclass(frozen=True)
class PcssTuning:
    """pcss's taps: the blocker search's and the filter's, how the search's taps crowd toward the
    receiver (the power of their spacing), whether a blocker must lie inside the triangle of
    the receiver and the segment, and whether the taps are jittered per pixel."""

    blocker_taps: int = 32
    filter_taps: int = 16
    search_power: float = 3.0
    in_triangle: bool = True
    jitter: bool = True


SHADERS = {"segment-maps": "segment_maps.frag", "pcss": "pcss.frag"}
# Sets of maps kept between frames: one per raster method, so that switching between them keeps
# both caches, while a sweep over K does not hold every K's maps at once.
KEPT_MAP_SETS = 2
# The window's maps look at the whole scene, not only at what the view shows, where that makes
# their texels at most this much coarser: a camera that moves then leaves the statics' maps
# cached. A map's width is bounded (map_frusta.MAX_TAN), so under a light that spans much of
# the scene the view's own maps are nearly as wide as the whole scene's already, and
# segment-maps' error is mostly its few points, not its texels (docs/design/raster-soft.md).
WHOLE_COARSER = 2.0
assert set(SHADERS) == set(RASTER_METHODS)
UNITS = {**TEXTURE_UNITS, "u_maps_compare": blocks.TEXTURE_UNITS["soft_maps"],
         "u_maps_depth": blocks.TEXTURE_UNITS["soft_maps_depth"]}


def light_points(method: str, a: np.ndarray, b: np.ndarray, settings: TraceSettings
                 ) -> np.ndarray:
    """The points a raster method draws maps from: K along the segment, or its centre."""
    if method == "pcss":
        return segment_points(a, b, 1)
    return segment_points(a, b, settings.maps)


def character_reach(geom: PackedGeometry, scene: Scene) -> np.ndarray:
    """The corners (8 per character, (8 C, 3)) of the boxes the characters can reach: their
    paths' bounds grown by their radius, as the tracer's grid bounds them."""
    corners = [np.zeros((0, 3))]
    for i, character in enumerate(scene.characters):
        path = np.asarray(character.path, np.float64)
        r = float(geom.character_radius[i])
        corners.append(box_corners(path.min(axis=0) - r, path.max(axis=0) + r))
    return np.vstack(corners)


class RasterSoft:
    """Owns every GL object of the raster soft methods for one scene."""

    def __init__(self, ctx, geom: PackedGeometry, scene: Scene, clock: str = "auto",
                 bias: MapBias = MapBias(), pcss: PcssTuning = PcssTuning()):
        self.ctx = ctx
        self.geom = geom
        self.timer = PassTimer(ctx, clock)
        self.bias = bias
        self.pcss = pcss
        self.cache_statics = True  # False draws the statics' maps every frame (to measure)
        self.cull_walkers = True   # False draws the closed walkers' back faces too (to measure)
        self.casters = scene_bounds(geom, scene)
        self.snap = float(np.linalg.norm(self.casters[1] - self.casters[0])) / SNAP_CELLS
        self.reach = character_reach(geom, scene)
        self._maps: dict[tuple[int, int], LightMaps] = {}
        self._refine: LightMaps | None = None   # a still window's maps from other points
        self._programs: dict[tuple, tuple] = {}
        self.compare = ctx.sampler(repeat_x=False, repeat_y=False,
                                   filter=(moderngl.LINEAR, moderngl.LINEAR), compare_func="<=")
        self.depth = ctx.sampler(repeat_x=False, repeat_y=False,
                                 filter=(moderngl.NEAREST, moderngl.NEAREST), compare_func="")
        self.target = self.framebuffer = None
        # The last trace's maps, frusta and segment, which :meth:`bind_lookup` binds.
        self.last: tuple[LightMaps, list, np.ndarray, np.ndarray] | None = None
        # What the last plan was made for, its frusta and the receivers' corners they look at.
        self._plan_memo: tuple = (None, None, None)
        # What the whole scene's plan was made for, its frusta and their corners.
        self._whole: tuple = (None, None, None)
        # The receivers' snapped corners (and the points and resolution) the last plan around
        # them was made for, and that plan: a turning camera often keeps the same cells.
        self._seen: tuple = (None, None)

    # -- ownership -------------------------------------------------------------------------------
    def gl_objects(self) -> int:
        """Maps, programs (with their shaders and vertex arrays), samplers, target."""
        programs = [p for p, _ in self._programs.values()]
        held = (self.target, self.framebuffer, self.compare, self.depth)
        maps = [*self._maps.values(), *([self._refine] if self._refine else [])]
        return (sum(m.gl_objects() for m in maps) + 2 * len(programs)
                + resources.attached_shaders(programs) + sum(x is not None for x in held)
                + self.timer.gl_objects())

    def release(self) -> None:
        for maps in self._maps.values():
            maps.release()
        self._maps = {}
        if self._refine is not None:
            self._refine.release()
            self._refine = None
        self.last = None
        self._plan_memo = self._whole = (None, None, None)
        self._seen = (None, None)
        for program, vao in self._programs.values():
            vao.release()
            program.release()
        self._programs = {}
        for obj in (self.framebuffer, self.target, self.compare, self.depth):
            if obj is not None:
                obj.release()
        self.framebuffer = self.target = self.compare = self.depth = None
        self.timer.release()

    def memory_bytes(self) -> dict[str, int]:
        """GPU memory of the maps, by count and resolution."""
        out = {f"maps_{k}x{r}": m.array.bytes for (k, r), m in self._maps.items()}
        if self._refine is not None:
            out["refine_maps"] = self._refine.array.bytes
        return out

    # -- parts -----------------------------------------------------------------------------------
    def _light_maps(self, count: int, resolution: int) -> LightMaps:
        """The maps of ``count`` points at ``resolution``, kept for later frames; the least
        recently used set goes when more than :data:`KEPT_MAP_SETS` would be held."""
        key = (count, resolution)
        maps = self._maps.pop(key, None)
        if maps is None:
            while len(self._maps) >= KEPT_MAP_SETS:
                self._maps.pop(next(iter(self._maps))).release()
            maps = LightMaps(self.ctx, self.geom, count, resolution)
        self._maps[key] = maps  # the most recently used last
        return maps

    def defines(self) -> dict:
        """The lookups' #defines: the maps' bias and pcss's taps (the soft composite's lookup
        variants build with them too)."""
        b, t = self.bias, self.pcss
        return {"MAX_SOFT_MAPS": LIMITS["maps"], "NORMAL_BIAS_TEXELS": float(b.normal),
                "DEPTH_BIAS_TEXELS": float(b.depth), "SLOPE_BIAS_TEXELS": float(b.slope),
                "MAX_SLOPE": float(b.max_slope), "BLOCKER_TAPS": t.blocker_taps,
                "FILTER_TAPS": t.filter_taps, "SEARCH_POWER": float(t.search_power),
                "IN_TRIANGLE": t.in_triangle, "JITTER": t.jitter}

    def _program(self, settings: TraceSettings):
        defines = self.defines()
        key = (settings.method, *sorted(defines.items()))
        if key not in self._programs:
            self._programs[key] = fullscreen_pass(self.ctx, SHADERS[settings.method], defines)
        return self._programs[key]

    def _target(self, size: tuple[int, int]):
        if self.target is None or self.target.size != tuple(size):
            if self.target is not None:
                self.framebuffer.release()
                self.target.release()
            self.target = self.ctx.texture(size, 1, dtype="f4")
            self.framebuffer = self.ctx.framebuffer([self.target])
        return self.framebuffer

    # -- the pass --------------------------------------------------------------------------------
    def trace(self, textures, size: tuple[int, int], models: np.ndarray,
              settings: TraceSettings, light: tuple[int, np.ndarray, np.ndarray],
              plan_key: bytes | None = None) -> TraceResult:
        """The linear light's visibility at every pixel of the G-buffer ``textures``
        (position, normal, colour), as :meth:`SoftTracer.trace` gives it.

        ``plan_key`` names what the plan depends on (the window's view, size and settings):
        while it stays the same the frusta are kept and the G-buffer is not read back. The
        walkers' pixels never enter the plan, so a walker that moves leaves it be."""
        mode, a, b = light
        if mode != blocks.TRACE_LIGHT_SEGMENT:
            raise ValueError(f"{settings.method} shadows a linear light only")
        w, h = size
        timer = self.timer
        timer.begin_frame()
        with timer.measure("total", wall=True):
            with timer.measure("plan", wall=True):
                memo = (plan_key, np.asarray(light[1:]).tobytes(), settings)
                if plan_key is None or memo != self._plan_memo[0]:
                    self._plan_memo = (memo, *self._plan(textures, size, settings, a, b,
                                                         view_free=plan_key is not None))
                frusta = self._plan_memo[1]
            with timer.measure("build_static"):  # the maps' one-off making counts here too
                maps = self._light_maps(len(frusta), settings.map_resolution)
                counts = maps.draw_statics(frusta, self.cache_statics)
            with timer.measure("build_dynamic"):
                maps.draw_walkers(frusta, models, counts, self.cull_walkers)
            self.last = (maps, frusta, a, b)
            with timer.measure("trace"):
                visibility = self._lookup(settings, textures, size)
        ms = dict(timer.ms)
        ms["build"] = ms["build_static"] + ms["build_dynamic"]
        vis = np.where(visibility < 0.0, np.nan, visibility).astype(np.float32)
        counters = {name: np.zeros((h, w), np.uint64 if name in BYTE_COUNTERS else np.uint32)
                    for name in COUNTERS}
        return TraceResult(visibility=vis, counters=counters, ms=ms,
                           samples_per_dispatch=len(frusta), rounds=1, maps=counts.stats())

    def _plan(self, textures, size: tuple[int, int], settings: TraceSettings, a: np.ndarray,
              b: np.ndarray, view_free: bool = False) -> tuple[list, np.ndarray]:
        """The frusta around the receivers of the G-buffer ``textures`` (read back), and the
        corners of the receivers' hull they look at. With ``view_free`` (the window), the
        frusta around the whole scene instead where they are at most :data:`WHOLE_COARSER`
        coarser: they stay whatever the view, so the statics' maps stay cached while the camera
        moves."""
        w, h = size
        positions = np.frombuffer(textures[0].read(), np.float32).reshape(h, w, 4)
        covered = np.frombuffer(textures[2].read(), np.uint8).reshape(h, w, 4)[..., 3] > 0
        # The walkers' own pixels are left out: where they can be is in the hull already, so
        # a walker that moves leaves the frusta, and the statics' maps, be.
        still = covered & (positions[..., 3] < self.geom.first_character)
        corners = np.vstack([receiver_cells(positions, still, self.snap), self.reach])
        points = light_points(settings.method, a, b, settings)
        key = (corners.tobytes(), np.asarray(points, np.float64).tobytes(),
               settings.map_resolution)
        if self._seen[0] != key:
            self._seen = (key, plan(points, corners, self.casters, settings.map_resolution))
        seen = self._seen[1]
        if not view_free:
            return seen, corners
        whole = self._whole_plan(points, settings.map_resolution)
        coarser = max(w.texel / s.texel for w, s in zip(whole, seen, strict=True))
        return (whole, self._whole[2]) if coarser <= WHOLE_COARSER else (seen, corners)

    def _whole_plan(self, points: np.ndarray, resolution: int) -> list:
        """The frusta from ``points`` around the whole scene: the same whatever the view, so
        made once for each light and resolution."""
        key = (np.asarray(points, np.float64).tobytes(), resolution)
        if self._whole[0] != key:
            corners = np.vstack([box_corners(*self.casters), self.reach])
            self._whole = (key, plan(points, corners, self.casters, resolution), corners)
        return self._whole[1]

    def refine_maps(self, settings: TraceSettings, phase: float, models: np.ndarray) -> tuple:
        """segment-maps' maps from K other points of the last trace's segment, each at
        ``phase`` of its part (the trace's are at the parts' centres), planned around the same
        receivers, the walkers at ``models`` drawn over the statics: what
        :meth:`bind_lookup` takes as ``maps``. A still window adds their lookups to what it
        kept (game/soft/still_lookups.py)."""
        _, frusta, a, b = self.last
        points = segment_points(a, b, len(frusta), phase)
        moved = plan(points, self._plan_memo[2], self.casters, settings.map_resolution)
        maps = self._refine
        if maps is None or (maps.count, maps.resolution) != (len(frusta),
                                                            settings.map_resolution):
            if maps is not None:
                maps.release()
            maps = self._refine = LightMaps(self.ctx, self.geom, len(frusta),
                                            settings.map_resolution)
        counts = maps.draw_statics(moved, True)
        maps.draw_walkers(moved, models, counts, self.cull_walkers)
        return (maps, moved, a, b)

    def _lookup(self, settings: TraceSettings, textures, size: tuple[int, int]) -> np.ndarray:
        """Draw the method's lookup into the target and read it back, row 0 at the top."""
        program, vao = self._program(settings)
        self.bind_lookup(program, settings.method)
        for tex, name in zip(textures, ("u_position", "u_normal", "u_colour"), strict=True):
            tex.use(UNITS[name])
            program[name].value = UNITS[name]
        fb = self._target(size)
        fb.use()
        fb.viewport = (0, 0, *size)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)
        out = np.frombuffer(fb.read(components=1, dtype="f4"), np.float32)
        self.ctx.detect_framebuffer(0).use()
        self.unbind_lookup()
        return out.reshape(size[1], size[0])[::-1]

    def bind_lookup(self, program, method: str, maps: tuple | None = None) -> None:
        """Set ``program``'s maps records (soft_maps.glsl) to the last trace's (or to ``maps``,
        as :meth:`refine_maps` gives them) and bind its maps and samplers: the lookup pass's
        program, or the soft composite's lookup variant."""
        maps, frusta, a, b = maps or self.last
        count = len(frusta)
        view_proj = np.zeros((LIMITS["maps"], 4, 4))
        view_proj[:count] = [f.view_proj for f in frusta]
        eyes = np.zeros((LIMITS["maps"], 4), np.float32)
        eyes[:count] = [(*f.eye, f.texel) for f in frusta]
        ranges = np.ones((LIMITS["maps"], 2), np.float32)
        ranges[:count] = [(f.near, f.far) for f in frusta]
        # The compiler trims an array to the elements a shader reads (pcss reads map 0 only).
        uniforms = {name: data[:program[name].array_length] for name, data in (
            ("u_view_proj", view_proj), ("u_map_eye", eyes), ("u_map_range", ranges))}
        uniforms["u_view_proj"] = transforms.gl_bytes(uniforms["u_view_proj"])
        uniforms["u_map_eye"] = uniforms["u_map_eye"].tobytes()
        uniforms["u_map_range"] = uniforms["u_map_range"].tobytes()
        if method == "pcss":
            uniforms["u_inv_view_proj"] = transforms.gl_bytes(np.linalg.inv(frusta[0].view_proj))
            uniforms["u_light_a"] = np.asarray(a, np.float32).tobytes()
            uniforms["u_light_b"] = np.asarray(b, np.float32).tobytes()
        for name, data in uniforms.items():
            program[name].write(data)
        program["u_map_count"].value = count
        program["u_dynamic"].value = maps.dynamic
        maps.bind(UNITS["u_maps_compare"])
        maps.bind(UNITS["u_maps_depth"])
        self.compare.use(UNITS["u_maps_compare"])
        self.depth.use(UNITS["u_maps_depth"])
        for name in ("u_maps_compare", "u_maps_depth"):
            if name in program:   # the compiler dropped what the method does not read
                program[name].value = UNITS[name]

    def unbind_lookup(self) -> None:
        """Take the samplers off the maps' units (other passes read plain textures there)."""
        for unit in (UNITS["u_maps_compare"], UNITS["u_maps_depth"]):
            self.ctx.clear_samplers(unit, unit + 1)

    def describe(self) -> dict:
        """What the stats report of the raster methods' settings."""
        return {"bias": asdict(self.bias), "pcss": asdict(self.pcss)}
