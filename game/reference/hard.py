"""The independent ground truth for hard shadows: a CPU ray cast with Embree.

It reads nothing but the dump files of docs/reference.md section 3 (``frame_kkkk.npz`` and
``frame_kkkk.glb``), so it shares no code, no shadow maps and no GL with the renderer it judges:
a bug in the renderer cannot hide itself by being repeated here.

For every pixel that sees geometry one shadow ray leaves the dumped world position (pushed off the
surface along the dumped normal) toward the light and asks Embree whether anything is in the way
(``rtcOccluded``, an any-hit query, cheaper than a closest hit); a scene of several lights casts
one ray per light through the same Embree scene. ``shadow_error`` then turns a method's ``lit``
image (or one layer of ``lit_lights``) and this reference into the project's accuracy number.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from game import gltf
from game.reference.dump_format import format_problem

# Shadow-ray start offset, as a fraction of the scene's bounding-box diagonal: large enough to step
# past the float32 rounding of the dumped position and of Embree's own arithmetic (both about
# 1e-7 of it), small enough (0.4 mm on a 40 m scene, 6 mm on a 570 m level) not to skip a real
# occluder near the receiver. Ten times more hid the layered roofs of a real level from the
# reference, and finer shadow maps, which do see them, scored worse than coarse ones.
RAY_OFFSET_SCENE = 1e-5
# Extra offset per metre of distance from the origin: float32 positions lose absolute precision far
# from the origin (about 1e-7 relative), and the renderer's reconstructed positions more so.
RAY_OFFSET_DISTANCE = 1e-5
# What a dump may declare (load_frame): a frame no larger than the command line allows, and
# arrays of at most this many 8-byte values per pixel (position and normal have 3 float32s,
# lit_lights one per light), or at most MAX_SMALL_BYTES (the names, the matrices).
MAX_DUMP_SIDE = 16384
MAX_DUMP_LIGHTS = 64   # the scene format's most lights: lit_lights' last axis
MAX_LAYERS_PER_PIXEL = MAX_DUMP_LIGHTS * np.dtype(np.float32).itemsize // 8
MAX_SMALL_BYTES = 64 * 2**20
MAX_DUMP_BYTES = 4 * 2**30   # all arrays together: an 8192x8192 dump is 1.6 GiB

# Pixels whose N.L is at or below this are left out of the error: at grazing angles the shadow
# boundary is ill-posed for every method, shadow maps and ray casts alike.
MIN_NDOTL = 0.1
# Node-name prefixes of objects that cast no shadow (docs/reference.md section 1: floors receive,
# never cast). Pass as ``skip_prefixes`` to ``load_geometry`` to build the occluders the format
# means.
NON_CASTER_PREFIXES = ("floor_",)

EMBREE_HINT = (
    "the shadow reference needs Embree: pip install embreex (or pip install -e '.[test]'); "
    "the pure-Python triangle ray caster is far too slow to stand in for it"
)


# What the reference needs of each light kind: whether its rays are parallel (it has no
# position), and whether a cone bounds what it lights. The reference keeps its own table: it
# judges the renderer and shares none of its code.
_KINDS = {"directional": (True, False), "spot": (False, True), "point": (False, False)}


@dataclass(frozen=True)
class Light:
    """The hard-shadow light as the reference needs it.

    ``direction`` is the way the light travels (directional and spot), ``position`` where it sits
    (spot and point), ``cone`` the spot's full cone angle in degrees, ``range`` the distance in
    metres beyond which a spot or point light lights nothing (None: no limit). The same keys as a
    scene file's light table, so ``Light.from_mapping(toml["light"])`` works. Colour and
    intensity are left out: they scale the light, they do not move its shadows.
    """

    kind: str
    direction: tuple[float, float, float] | None = None
    position: tuple[float, float, float] | None = None
    cone: float | None = None
    range: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            raise ValueError(f"unknown light kind {self.kind!r}")
        if self.parallel and self.direction is None:
            raise ValueError(f"a {self.kind} light needs a direction")
        if not self.parallel and self.position is None:
            raise ValueError(f"a {self.kind} light needs a position")
        if self.range is not None:
            if self.parallel:
                raise ValueError(f"a {self.kind} light has no range")
            if not self.range > 0.0:
                raise ValueError(f"a light's range must be positive, got {self.range}")

    @property
    def parallel(self) -> bool:
        """Whether its rays are parallel: a sun, with a direction and no position."""
        return _KINDS[self.kind][0]

    @property
    def coned(self) -> bool:
        """Whether a cone bounds what it lights (a spot light)."""
        return _KINDS[self.kind][1]

    @classmethod
    def from_mapping(cls, light: Mapping[str, Any]) -> Light:
        """Build from a ``[light]``-like table; unknown keys are ignored."""

        def vec(key: str) -> tuple[float, float, float] | None:
            value = light.get(key)
            if value is None:
                return None
            x, y, z = (float(v) for v in value)
            return (x, y, z)

        def number(key: str) -> float | None:
            value = light.get(key)
            return None if value is None else float(value)

        return cls(
            kind=str(light["kind"]),
            direction=vec("direction"),
            position=vec("position"),
            cone=number("cone"),
            range=number("range"),
        )


def as_light(light: Light | Mapping[str, Any] | Any) -> Light:
    """Accept a ``Light``, a ``[light]``-like mapping, or any object with the same attributes.

    The last one lets callers pass a loaded scene's light without this module importing the
    scene loader: the reference stays independent of the code it checks.
    """
    if isinstance(light, Light):
        return light
    if isinstance(light, Mapping):
        return Light.from_mapping(light)
    fields = ("kind", "direction", "position", "cone", "range")
    return Light.from_mapping({key: getattr(light, key, None) for key in fields})


def load_frame(npz_path: str | Path) -> dict[str, Any]:
    """Read one ``frame_kkkk.npz`` dump into plain numpy values.

    ``names`` becomes a list of str, ``size`` a (W, H) tuple and ``time`` a float; every other
    array is returned as stored. No pickles are loaded: a dump is data, not code.
    """
    with np.load(npz_path, allow_pickle=False) as data:
        check_declared_sizes(data, Path(npz_path).name)
        frame: dict[str, Any] = {key: data[key] for key in data.files}
    if "names" in frame:
        frame["names"] = [str(name) for name in frame["names"]]
    if "size" in frame:
        frame["size"] = tuple(int(x) for x in np.ravel(frame["size"]))
    if "time" in frame:
        frame["time"] = float(frame["time"])
    return frame


def _declared(data, key: str) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype an npz member declares in its header, read without its data."""
    with data.zip.open(f"{key}.npy") as member:
        version = np.lib.format.read_magic(member)
        read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                else np.lib.format.read_array_header_2_0)
        shape, _fortran, dtype = read(member)
    return tuple(int(n) for n in shape), np.dtype(dtype)


def check_declared_sizes(data, name: str = "the dump") -> None:
    """Refuse a dump (the file ``name``) whose arrays are larger than its own frame size allows,
    or not of the type and shape the format says (game/reference/dump_format.py), before
    reading any of them: a few megabytes of npz can otherwise unpack into tens of gigabytes."""
    if "size" not in data.files:
        raise ValueError(f"{name}: no 'size' array")
    shape, dtype = _declared(data, "size")
    if shape != (2,) or dtype.kind not in "iu":
        raise ValueError("'size' is not two whole numbers")
    w, h = (int(v) for v in data["size"])
    if not (1 <= w <= MAX_DUMP_SIDE and 1 <= h <= MAX_DUMP_SIDE):
        raise ValueError(f"'size' {w}x{h} is not a frame size (1..{MAX_DUMP_SIDE} per side)")
    limit = max(MAX_LAYERS_PER_PIXEL * 8 * w * h, MAX_SMALL_BYTES)
    total = 0.0
    for key in data.files:
        shape, dtype = _declared(data, key)
        size = float(np.prod(shape, dtype=np.float64)) * dtype.itemsize
        expected = {"position": (h, w, 3), "normal": (h, w, 3), "lit": (h, w),
                    "object": (h, w), "soft": (h, w)}.get(key)
        wrong_shape = expected is not None and shape != expected
        if key == "lit_lights":  # one layer per light
            wrong_shape = not (len(shape) == 3 and shape[:2] == (h, w)
                               and 1 <= shape[2] <= MAX_DUMP_LIGHTS)
        if size > limit or wrong_shape:
            raise ValueError(f"array {key!r} declares {shape} of {dtype}, not what a "
                             f"{w}x{h} frame holds")
        problem = format_problem(key, shape, dtype, w, h)
        if problem is not None:
            raise ValueError(f"{name}: {problem}")
        total += size
    if total > MAX_DUMP_BYTES:
        raise ValueError(f"its arrays declare {total / 2**30:.1f} GiB, more than the "
                         f"{MAX_DUMP_BYTES / 2**30:.0f} GiB a dump may hold")


def load_geometry(glb_path: str | Path, skip_prefixes: tuple[str, ...] = ()) -> trimesh.Trimesh:
    """All nodes of a ``frame_kkkk.glb`` in world space, concatenated into one mesh.

    Node transforms are applied, so instanced or moved objects land where the frame saw them.
    Nodes whose name starts with one of ``skip_prefixes`` are left out (``NON_CASTER_PREFIXES``
    drops the floors, which the format says cast no shadows).
    """
    return geometry_from_glb(Path(glb_path).read_bytes(), skip_prefixes)


def geometry_from_glb(data: bytes, skip_prefixes: tuple[str, ...] = ()) -> trimesh.Trimesh:
    """:func:`load_geometry` of a glb file's bytes.

    A dump's glb carries its geometry inside: a URI to any other file is refused, and images
    are never decoded (game/gltf.py). Raises ValueError for a glb that cannot be read so.
    """
    data = gltf.safe_glb(data)
    # process=False: keep the triangles exactly as written, no merging or reordering.
    scene = trimesh.load(io.BytesIO(data), file_type="glb", force="scene", process=False)
    parts = []
    for node in sorted(scene.graph.nodes_geometry):
        if node.startswith(skip_prefixes):
            continue
        transform, geometry_name = scene.graph[node]
        geometry = scene.geometry[geometry_name]
        if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
            continue
        parts.append(geometry.copy().apply_transform(transform))
    if not parts:
        return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)
    return trimesh.util.concatenate(parts)


def _to_light(light: Light, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions from (N, 3) points toward the light, and the distance to it (inf if none)."""
    if light.parallel:
        direction = -np.asarray(light.direction, dtype=np.float64)
        direction = direction / np.linalg.norm(direction)
        return np.broadcast_to(direction, position.shape), np.full(len(position), np.inf)
    offset = np.asarray(light.position, dtype=np.float64) - position
    distance = np.linalg.norm(offset, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        direction = offset / distance[:, None]
    return direction, distance


def _n_dot_l(light: Light, position: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """N.L per pixel of (H, W, 3) images; NaN where there is no geometry."""
    flat_p = position.reshape(-1, 3).astype(np.float64)
    flat_n = normal.reshape(-1, 3).astype(np.float64)
    direction, _ = _to_light(light, flat_p)
    return np.einsum("ij,ij->i", flat_n, direction).reshape(position.shape[:-1])


class _Caster:
    """The occluders as one Embree scene, built on first use and cast through for every light."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        self.mesh = mesh
        self._scene = None
        # Embree works in float32: recentre on the scene so coordinates stay small and precise.
        self._centre = mesh.bounds.mean(axis=0) if len(mesh.faces) else np.zeros(3)

    def occluded(self, origins: np.ndarray, directions: np.ndarray,
                 tfar: np.ndarray) -> np.ndarray:
        """Embree any-hit query: does each ray segment [0, tfar) hit the mesh?"""
        if self._scene is None:
            try:
                from embreex import rtcore_scene
                from embreex.mesh_construction import TriangleMesh
            except ImportError as error:
                raise RuntimeError(EMBREE_HINT) from error
            self._scene = rtcore_scene.EmbreeScene()
            TriangleMesh(
                scene=self._scene,
                vertices=(self.mesh.vertices - self._centre).astype(np.float32),
                indices=np.asarray(self.mesh.faces, dtype=np.int32),
            )
        # A directional light has no far end: clamp inf to the largest float32 rather than rely
        # on how inf survives the cast and Embree's ray setup.
        far = np.minimum(tfar, np.finfo(np.float32).max).astype(np.float32)
        hits = self._scene.run(
            (origins - self._centre).astype(np.float32),
            np.ascontiguousarray(directions, dtype=np.float32),
            dists=far,
            query="OCCLUDED",
        )
        # embreex answers an OCCLUDED query with 0 for a blocked ray and -1 for a free one.
        return np.asarray(hits) != -1


def hard_visibility(
    mesh: trimesh.Trimesh,
    position: np.ndarray,
    normal: np.ndarray,
    light: Light | Mapping[str, Any] | Any,
) -> np.ndarray:
    """Exact hard-shadow visibility of each dumped pixel, by one Embree shadow ray per pixel.

    Parameters
    ----------
    mesh
        The occluders in world space (``load_geometry``).
    position, normal
        (H, W, 3) dumped world positions and unit normals; NaN where no geometry.
    light
        A ``Light``, a ``[light]``-like mapping or an object with the same attributes. Spot
        lights are treated as point lights, and a light's range is not applied: this is
        visibility, and the cone and the range end the light's reach, they occlude nothing
        (``shadow_error`` leaves out the pixels they do not reach).

    Returns
    -------
    (H, W) float32: 1 lit, 0 shadowed (occluded, or facing away from the light: N.L <= 0, the
    light cannot reach the surface), NaN where there is no geometry.
    """
    return hard_visibility_lights(mesh, position, normal, [light])[0]


def hard_visibility_lights(
    mesh: trimesh.Trimesh,
    position: np.ndarray,
    normal: np.ndarray,
    lights: Sequence[Light | Mapping[str, Any] | Any],
    offset_scale: float = 1.0,
) -> list[np.ndarray]:
    """:func:`hard_visibility` toward each of ``lights``, through one Embree scene built once;
    ``offset_scale`` scales the rays' start offset (game/reference/offsets.py probes with it)."""
    caster = _Caster(mesh)
    return [_visibility(caster, position, normal, as_light(light), offset_scale)
            for light in lights]


def _visibility(caster: _Caster, position: np.ndarray, normal: np.ndarray,
                light: Light, offset_scale: float) -> np.ndarray:
    mesh = caster.mesh
    shape = position.shape[:-1]
    flat_p = position.reshape(-1, 3).astype(np.float64)
    flat_n = normal.reshape(-1, 3).astype(np.float64)
    lit = np.full(flat_p.shape[0], np.nan, dtype=np.float32)

    valid = np.isfinite(flat_p).all(axis=1) & np.isfinite(flat_n).all(axis=1)
    p, n = flat_p[valid], flat_n[valid]
    direction, _ = _to_light(light, p)
    facing = np.einsum("ij,ij->i", n, direction) > 0.0

    result = np.where(facing, 1.0, 0.0).astype(np.float32)
    if facing.any() and len(mesh.faces) > 0:
        p, n = p[facing], n[facing]
        # The scene is the occluders and the receivers together: floors may be left out of mesh.
        corners = np.vstack([mesh.bounds, p.min(axis=0), p.max(axis=0)])
        diagonal = float(np.linalg.norm(corners.max(axis=0) - corners.min(axis=0)))
        eps = RAY_OFFSET_SCENE * diagonal + RAY_OFFSET_DISTANCE * np.linalg.norm(p, axis=1)
        eps *= offset_scale
        origins = p + n * eps[:, None]
        # Aim from the pushed-off origin and stop at the light: only hits nearer than a point
        # light count, anything behind it cannot shadow.
        direction, distance = _to_light(light, origins)
        blocked = caster.occluded(origins, direction, distance)
        result[facing] = np.where(blocked, 0.0, 1.0)
    lit[valid] = result
    return lit.reshape(shape)


def shadow_error(
    lit_method: np.ndarray,
    lit_reference: np.ndarray,
    position: np.ndarray,
    normal: np.ndarray,
    light: Light | Mapping[str, Any] | Any,
    min_ndotl: float = MIN_NDOTL,
    left_out: np.ndarray | None = None,
) -> dict[str, Any]:
    """The accuracy metric: misclassified pixels per pixel that either side shadows.

    Only pixels with geometry, with N.L > ``min_ndotl``, for a spot light with a ``cone`` inside
    the cone and, for a light with a ``range``, within that distance of the light are considered:
    elsewhere the light does not reach and a method's ``lit`` is free to say anything. A pixel
    is misclassified when the method and the reference disagree about ``lit >= 0.5``; a NaN in
    ``lit_method`` where there is geometry reads as shadowed. Pixels of the (H, W) bool
    ``left_out`` (where the reference changes with the ray offset) are not considered either.

    Returns ``{"error", "misclassified", "shadowed", "shadowed_either", "considered",
    "left_out_reach", "left_out_offset"}`` and the (H, W) bool images ``mask`` (misclassified),
    ``considered_mask`` and ``offset_mask``: ``shadowed`` counts the pixels the reference
    shadows, ``shadowed_either`` those that the method or the reference shadows, and ``error``
    is ``misclassified / max(1, shadowed_either)``. Every misclassified pixel is shadowed on one
    side, so the error lies in [0, 1]: 1 - the intersection over union of the two shadow masks.
    ``left_out_reach`` counts the pixels with geometry left out by N.L, cone or range,
    ``left_out_offset`` the further ones left out by ``left_out``.
    """
    light = as_light(light)
    has_geometry = np.isfinite(position).all(axis=-1) & np.isfinite(normal).all(axis=-1)
    has_geometry &= np.isfinite(lit_reference)
    with np.errstate(invalid="ignore"):
        considered = has_geometry & (_n_dot_l(light, position, normal) > min_ndotl)
        if light.coned and light.cone is not None and light.direction is not None:
            considered &= _inside_cone(light, position)
        if light.range is not None:
            considered &= _within_range(light, position)
        reached = considered.copy()
        offset_mask = reached & (False if left_out is None else left_out)
        considered &= ~offset_mask
        method_lit = lit_method >= 0.5
        reference_lit = lit_reference >= 0.5
    mask = considered & (method_lit != reference_lit)
    misclassified = int(mask.sum())
    shadowed = int((considered & ~reference_lit).sum())
    shadowed_either = int((considered & ~(reference_lit & method_lit)).sum())
    return {
        "error": misclassified / max(1, shadowed_either),
        "misclassified": misclassified,
        "shadowed": shadowed,
        "shadowed_either": shadowed_either,
        "considered": int(considered.sum()),
        "left_out_reach": int((has_geometry & ~reached).sum()),
        "left_out_offset": int(offset_mask.sum()),
        "mask": mask, "considered_mask": considered, "offset_mask": offset_mask,
    }


def _inside_cone(light: Light, position: np.ndarray) -> np.ndarray:
    """Whether each (H, W, 3) point lies inside a spot light's cone."""
    axis = np.asarray(light.direction, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    offset = position.astype(np.float64) - np.asarray(light.position, dtype=np.float64)
    cos_angle = (offset @ axis) / np.linalg.norm(offset, axis=-1)
    return cos_angle >= np.cos(np.radians(0.5 * float(light.cone)))


def _within_range(light: Light, position: np.ndarray) -> np.ndarray:
    """Whether each (H, W, 3) point lies nearer to a spot or point light than its range: the
    light lights nothing at its range and beyond."""
    offset = position.astype(np.float64) - np.asarray(light.position, dtype=np.float64)
    return np.linalg.norm(offset, axis=-1) < float(light.range)
