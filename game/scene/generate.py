"""Procedural towns for benchmarks: the ``[generate]`` table of a scene file.

A town is a square grid of ``blocks`` x ``blocks`` city blocks separated by streets, on one floor
that covers it all. Each block is cut into a grid of lots; a random choice of lots holds buildings
(boxes with a cornice, a roof housing and protruding window frames and ledges) and trees (a
cylinder trunk with a sphere or cone crown). Walkers are capsules looping around rectangles of
blocks, in the streets, so they never walk through a static.

Speed matters here: a 1 M-triangle town must build in a few seconds. Templates (unit box, unit
cylinder, unit sphere, unit cone) are built once, and every building or tree is made by scaling
and offsetting template vertices with numpy; trimesh is only used to wrap the final arrays, with
``process=False``. Every building and every tree stays its own mesh, so that each is its own named
static object in the scene.

The table's keys, with their defaults, are :class:`TownParams`; docs/scenes.md documents them.
"""

from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any, NoReturn

import numpy as np
import trimesh

from game.errors import SceneError
from game.scene.shapes import capsule_mesh, transform_mesh
from game.transforms import euler_xyz

STOREY_HEIGHT = 3.0  # metres
MIN_STOREYS = 2
WINDOW_PITCH_AT_DETAIL_0 = 4.0  # metres between window centres; divided by (1 + detail)
WINDOW_HEIGHT = 1.4  # metres
WINDOW_SILL_Y = 0.9  # metres above each storey's floor
WINDOW_PROTRUSION = 0.12  # metres a window frame stands out of the wall
LEDGE_PROTRUSION = 0.2  # metres a storey ledge or the cornice stands out of the wall
LEDGE_THICKNESS = 0.25  # metres
CORNICE_HEIGHT = 0.6  # metres
ROOF_HOUSING_HEIGHT = 2.5  # metres
LOT_MARGIN = 0.4  # metres kept free between a building's outermost detail and its lot edge
FOOTPRINT_FRACTION = (0.55, 0.8)  # of the lot side, per axis
MIN_LOT_SIDE = 3.0  # metres: room for a small building or tree inside its margins

TREE_CROWN_RADIUS = (1.2, 2.6)  # metres, before clamping to the lot
TREE_TRUNK_HEIGHT = (1.5, 3.0)  # metres
CONIFER_FRACTION = 0.35  # of trees with a cone crown instead of a sphere
MAX_CROWN_SUBDIVISIONS = 5  # icosphere subdivisions at the highest detail (20480 triangles)

WALKER_RADIUS = 0.3  # metres
WALKER_HEIGHT = 1.8  # metres, total
WALKER_CLEARANCE = 0.9  # metres from a block edge: capsule radius + window frames + a margin
WALKER_SPEED = (0.8, 2.2)  # metres per second
FLOOR_THICKNESS = 0.2  # metres; the floor's top is y = 0

LAMP_SETBACK = 0.3  # metres from a block's edge into the street: inside the walkers' clearance
LAMP_POST_RADIUS = 0.08  # metres
LAMP_HEIGHT = 4.6  # metres, the top of the post
LAMP_ARM = 0.9  # metres the arm reaches over the street
LAMP_HEAD = np.array([0.35, 0.2, 0.35])  # metres, the lamp's housing at the arm's end
LAMP_LIGHT_DROP = 0.3  # metres from the arm down to the light, under the housing
LAMP_COLOUR = (1.0, 0.78, 0.5)  # sodium-warm, sRGB
LAMP_INTENSITY = 1.5


@dataclass(frozen=True)
class TownParams:
    """The ``[generate]`` keys and their defaults."""

    seed: int = 0  # numpy default_rng seed: the same seed builds the same town
    blocks: int = 4  # blocks per side of the square town
    block_size: float = 40.0  # metres, the side of one block
    street_width: float = 10.0  # metres between blocks (and around the town)
    buildings_per_block: int = 4
    trees_per_block: int = 4
    max_storeys: int = 8  # buildings have 2 ..= max_storeys storeys of 3 m
    detail: int = 1  # tessellation: window frames per facade and tree-crown subdivisions
    characters: int = 8  # walkers
    lamps: int = 0  # street lamps, each a static post and a light
    lamp_range: float = 16.0  # metres a lamp's light reaches
    lamp_cone: float = 0.0  # 0: point lights; else spot lights pointing down with this cone


# The most triangles the parameters may allow (triangle_bound, about twice what a town gets):
# memory grows with them, and the 1 M-triangle town's parameters allow 1.9 M.
MAX_TRIANGLE_BOUND = 16_000_000

# (type, lowest, highest) of every key; floats accept integers.
PARAM_LIMITS: dict[str, tuple[type, float, float]] = {
    "seed": (int, 0, 2**63 - 1),
    "blocks": (int, 1, 64),
    "block_size": (float, 10.0, 1000.0),
    "street_width": (float, 4.0, 200.0),
    "buildings_per_block": (int, 0, 256),
    "trees_per_block": (int, 0, 256),
    "max_storeys": (int, MIN_STOREYS, 100),
    "detail": (int, 0, 5),
    "characters": (int, 0, 4096),
    "lamps": (int, 0, 1024),
    "lamp_range": (float, 1.0, 1000.0),
    "lamp_cone": (float, 0.0, 179.0),
}


@dataclass
class Walker:
    """A generated character: local mesh (centred), closed path (K, 3), speed, phase."""

    mesh: trimesh.Trimesh
    path: np.ndarray
    speed: float
    phase: float


@dataclass(frozen=True)
class Lamp:
    """A generated street lamp's light: where it is, and which way a spot lamp points."""

    position: np.ndarray
    cone: float  # 0: a point light; else a spot light's full cone, pointing down
    range: float


@dataclass
class Town:
    """World-space meshes of the generated floors and statics, the walkers and the lamps (whose
    posts are the last statics)."""

    floors: list[trimesh.Trimesh]
    statics: list[trimesh.Trimesh]
    walkers: list[Walker]
    lamps: list[Lamp] = field(default_factory=list)

    def static_triangles(self) -> int:
        """Triangles over all statics."""
        return sum(len(m.faces) for m in self.statics)


def _default_fail(key: str, problem: str) -> NoReturn:
    raise SceneError(f"generate.{key}: {problem}")


def town_params(table: Mapping[str, Any],
                fail: Callable[[str, str], NoReturn] | None = None) -> TownParams:
    """Validate a ``[generate]`` table.

    Parameters
    ----------
    table
        The parsed TOML table.
    fail
        Called with (key, problem) to raise the error; the scene loader passes one that adds the
        file and line. The default raises ``SceneError("generate.<key>: <problem>")``.
    """
    fail = fail or _default_fail
    names = [f.name for f in fields(TownParams)]
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in names:
            close = difflib.get_close_matches(key, names, n=1)
            fail(key, "unknown key" + (f", did you mean '{close[0]}'?" if close
                                       else f" (expected one of: {', '.join(names)})"))
        kind, low, high = PARAM_LIMITS[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            fail(key, f"must be a number, got {value!r}")
        if kind is int and not isinstance(value, int):
            fail(key, f"must be an integer, got {value!r}")
        # Compared as given, so that a 400-digit integer is out of range, not an overflow.
        if isinstance(value, float) and not math.isfinite(value):
            fail(key, f"must be finite, got {value}")
        if not low <= value <= high:
            digits = str(value)
            shown = digits if len(digits) < 16 else f"{digits[:12]}... ({len(digits)} digits)"
            fail(key, f"must be between {low:g} and {high:g}, got {shown}")
        values[key] = kind(value)
    params = TownParams(**values)
    if _lot_side(params) < MIN_LOT_SIDE:
        key = "buildings_per_block" if "buildings_per_block" in table else "block_size"
        fail(key, f"too many buildings and trees for block_size {params.block_size:g}: "
                  f"lots would be {_lot_side(params):.2f} m, at least {MIN_LOT_SIDE:g} m needed")
    bound = triangle_bound(params)
    if bound > MAX_TRIANGLE_BOUND:
        key = next((k for k in ("blocks", "detail", "max_storeys", "buildings_per_block")
                    if k in table), "blocks")
        fail(key, f"these parameters could build up to {bound:,} triangles, more than the "
                  f"{MAX_TRIANGLE_BOUND:,} a generated town may have (fewer blocks, storeys, "
                  "buildings or less detail)")
    return params


# --------------------------------------------------------------------------------------------
# Templates and instancing


_UNIT_BOX = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
_BOX_CORNERS = np.asarray(_UNIT_BOX.vertices, dtype=np.float64) + 0.5  # in [0, 1]^3
_BOX_FACES = np.asarray(_UNIT_BOX.faces, dtype=np.int64)


def boxes(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (8N, 3) and faces (12N, 3) of N axis-aligned boxes from corners (N, 3)."""
    lo, hi = np.atleast_2d(lo), np.atleast_2d(hi)
    vertices = lo[:, None, :] + (hi - lo)[:, None, :] * _BOX_CORNERS[None]
    faces = _BOX_FACES[None] + 8 * np.arange(len(lo))[:, None, None]
    return vertices.reshape(-1, 3), faces.reshape(-1, 3)


def _mesh(parts: list[tuple[np.ndarray, np.ndarray]]) -> trimesh.Trimesh:
    """One mesh from (vertices, faces) parts, offsetting the face indices."""
    offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    vertices = np.concatenate([v for v, _ in parts])
    faces = np.concatenate([f + o for (_, f), o in zip(parts, offsets, strict=True)])
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


@dataclass(frozen=True)
class _Templates:
    """Unit meshes for the trees as (vertices, faces), built once per detail level."""

    trunk: tuple[np.ndarray, np.ndarray]  # radius 1, height 1, along +Y, centred
    sphere: tuple[np.ndarray, np.ndarray]  # radius 1, centred
    cone: tuple[np.ndarray, np.ndarray]  # radius 1, height 1, apex up, base at y = 0


def _arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


@functools.lru_cache(maxsize=8)
def _templates(detail: int) -> _Templates:
    # trimesh builds cylinders and cones along +Z, the cone's base at z = 0.
    z_to_y = euler_xyz([-90.0, 0.0, 0.0])
    trunk = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=6 + 2 * detail)
    sphere = trimesh.creation.icosphere(subdivisions=min(detail + 1, MAX_CROWN_SUBDIVISIONS))
    cone = trimesh.creation.cone(radius=1.0, height=1.0, sections=8 * (detail + 1))
    return _Templates(trunk=_arrays(transform_mesh(trunk, z_to_y)), sphere=_arrays(sphere),
                      cone=_arrays(transform_mesh(cone, z_to_y)))


def _place(template: tuple[np.ndarray, np.ndarray], scale: Any,
           offset: Any) -> tuple[np.ndarray, np.ndarray]:
    """A template scaled per axis, then moved by ``offset``."""
    vertices, faces = template
    return vertices * np.asarray(scale) + np.asarray(offset), faces


# --------------------------------------------------------------------------------------------
# Buildings, trees and walkers


def _window_boxes(centre: np.ndarray, half: np.ndarray, axis: int, sign: float, storeys: int,
                  pitch: float, sills: bool) -> tuple[np.ndarray, np.ndarray]:
    """Corners (lo, hi) of the window frames (and sills) of the facade facing ``sign * axis``.

    Frames straddle the wall plane, so half of each box is hidden inside the building and the
    other half stands out by WINDOW_PROTRUSION; no box needs to know which side is outside.
    """
    other = 2 - axis  # the facade's horizontal direction: x for a z-facing facade and back
    span = 2.0 * half[other]
    columns = max(1, int(span // pitch))
    width = 0.6 * span / columns
    u = centre[other] - half[other] + (np.arange(columns) + 0.5) * span / columns
    y = np.arange(storeys) * STOREY_HEIGHT + WINDOW_SILL_Y
    uu, yy = (a.ravel() for a in np.meshgrid(u, y))
    wall = centre[axis] + sign * half[axis]
    lo, hi = np.empty((len(uu), 3)), np.empty((len(uu), 3))
    lo[:, other], hi[:, other] = uu - 0.5 * width, uu + 0.5 * width
    lo[:, 1], hi[:, 1] = yy, yy + WINDOW_HEIGHT
    lo[:, axis], hi[:, axis] = wall - WINDOW_PROTRUSION, wall + WINDOW_PROTRUSION
    if not sills:
        return lo, hi
    sill_lo, sill_hi = lo.copy(), hi.copy()
    sill_lo[:, other] -= 0.1
    sill_hi[:, other] += 0.1
    sill_lo[:, 1], sill_hi[:, 1] = yy - 0.12, yy
    sill_lo[:, axis], sill_hi[:, axis] = wall - 2 * WINDOW_PROTRUSION, wall + 2 * WINDOW_PROTRUSION
    return np.concatenate([lo, sill_lo]), np.concatenate([hi, sill_hi])


def _building(rng: np.random.Generator, x: float, z: float, width: float, depth: float,
              storeys: int, detail: int) -> trimesh.Trimesh:
    """A box building standing on y = 0 with a cornice, a roof housing, ledges and windows."""
    height = storeys * STOREY_HEIGHT
    centre = np.array([x, 0.0, z])
    half = np.array([0.5 * width, 0.0, 0.5 * depth])
    p = LEDGE_PROTRUSION
    lo = [[x - half[0], 0.0, z - half[2]], [x - half[0] - p, height, z - half[2] - p]]
    hi = [[x + half[0], height, z + half[2]],
          [x + half[0] + p, height + CORNICE_HEIGHT, z + half[2] + p]]
    # The roof housing stands on the cornice, somewhere on the roof.
    hw, hd = 0.5 * width * rng.uniform(0.2, 0.4), 0.5 * depth * rng.uniform(0.2, 0.4)
    hx = x + rng.uniform(-1.0, 1.0) * (half[0] - hw)
    hz = z + rng.uniform(-1.0, 1.0) * (half[2] - hd)
    top = height + CORNICE_HEIGHT
    lo.append([hx - hw, top, hz - hd])
    hi.append([hx + hw, top + ROOF_HOUSING_HEIGHT, hz + hd])
    if detail >= 1:  # a ledge slab through the building between storeys
        ys = np.arange(1, storeys) * STOREY_HEIGHT
        for y in ys:
            lo.append([x - half[0] - p, y - 0.5 * LEDGE_THICKNESS, z - half[2] - p])
            hi.append([x + half[0] + p, y + 0.5 * LEDGE_THICKNESS, z + half[2] + p])
    los, his = [np.array(lo)], [np.array(hi)]
    pitch = WINDOW_PITCH_AT_DETAIL_0 / (1 + detail)
    for axis in (0, 2):
        for sign in (-1.0, 1.0):
            w_lo, w_hi = _window_boxes(centre, half, axis, sign, storeys, pitch, detail >= 2)
            los.append(w_lo)
            his.append(w_hi)
    return _mesh([boxes(np.concatenate(los), np.concatenate(his))])


def _tree(templates: _Templates, x: float, z: float, crown: float, trunk: float,
          conifer: bool) -> trimesh.Trimesh:
    """A trunk standing on y = 0 with a cone or sphere crown that overlaps its top."""
    trunk_radius = 0.08 + 0.08 * crown
    parts = [_place(templates.trunk, (trunk_radius, trunk, trunk_radius), (x, 0.5 * trunk, z))]
    if conifer:
        parts.append(_place(templates.cone, (crown, 2.5 * crown, crown), (x, 0.6 * trunk, z)))
    else:
        parts.append(_place(templates.sphere, crown, (x, trunk + 0.75 * crown, z)))
    return _mesh(parts)


def triangle_bound(params: TownParams) -> int:
    """An upper bound on the town's static triangles, from the parameters alone: every building
    at the widest footprint and the most storeys, every tree with the larger crown."""
    lot = _lot_side(params)
    pitch = WINDOW_PITCH_AT_DETAIL_0 / (1 + params.detail)
    columns = max(1, int(min(FOOTPRINT_FRACTION[1] * lot, lot - 2.0 * LOT_MARGIN) // pitch))
    storeys = params.max_storeys
    per_building = (3 + (storeys - 1 if params.detail >= 1 else 0)
                    + 4 * columns * storeys * (2 if params.detail >= 2 else 1))
    templates = _templates(params.detail)
    per_tree = len(templates.trunk[1]) + max(len(templates.sphere[1]), len(templates.cone[1]))
    per_block = (params.buildings_per_block * len(_BOX_FACES) * per_building
                 + params.trees_per_block * per_tree)
    return params.blocks ** 2 * per_block


def _lot_side(params: TownParams) -> float:
    """The side of one lot: blocks are cut into the smallest square grid holding every object."""
    per_block = params.buildings_per_block + params.trees_per_block
    return params.block_size / max(1, math.ceil(math.sqrt(per_block)))


def generate_town(params: TownParams | Mapping[str, Any]) -> Town:
    """Build the town of a ``[generate]`` table (or of validated :class:`TownParams`).

    The same parameters always build the same town: every random choice comes from one
    ``numpy.random.default_rng(seed)``, drawn in a fixed order.
    """
    if not isinstance(params, TownParams):
        params = town_params(params)
    rng = np.random.default_rng(params.seed)
    n, size, street = params.blocks, params.block_size, params.street_width
    pitch = size + street
    centres = (np.arange(n) - 0.5 * (n - 1)) * pitch
    half_town = 0.5 * n * pitch + 0.5 * street  # a full street runs around the outside
    floor = _mesh([boxes(np.array([-half_town, -FLOOR_THICKNESS, -half_town]),
                         np.array([half_town, 0.0, half_town]))])

    templates = _templates(params.detail)
    per_block = params.buildings_per_block + params.trees_per_block
    grid = max(1, math.ceil(math.sqrt(per_block)))
    lot = _lot_side(params)
    statics: list[trimesh.Trimesh] = []
    for bx in centres:
        for bz in centres:
            cells = rng.permutation(grid * grid)[:per_block]
            lot_x = bx - 0.5 * size + (cells // grid + 0.5) * lot
            lot_z = bz - 0.5 * size + (cells % grid + 0.5) * lot
            for k in range(per_block):
                if k < params.buildings_per_block:
                    width, depth = np.minimum(lot * rng.uniform(*FOOTPRINT_FRACTION, 2),
                                              lot - 2.0 * LOT_MARGIN)
                    slack = 0.5 * (lot - np.array([width, depth])) - LOT_MARGIN
                    x, z = (lot_x[k], lot_z[k]) + rng.uniform(-1.0, 1.0, 2) * slack
                    storeys = int(rng.integers(MIN_STOREYS, params.max_storeys + 1))
                    statics.append(_building(rng, x, z, width, depth, storeys, params.detail))
                else:
                    crown = min(rng.uniform(*TREE_CROWN_RADIUS), 0.5 * lot - LOT_MARGIN)
                    slack = 0.5 * lot - LOT_MARGIN - crown
                    x, z = (lot_x[k], lot_z[k]) + rng.uniform(-1.0, 1.0, 2) * slack
                    trunk = rng.uniform(*TREE_TRUNK_HEIGHT)
                    conifer = bool(rng.random() < CONIFER_FRACTION)
                    statics.append(_tree(templates, x, z, crown, trunk, conifer))

    walker_mesh = capsule_mesh(WALKER_RADIUS, WALKER_HEIGHT)
    walkers = []
    for _ in range(params.characters):
        # A loop around a rectangle of blocks, in the street at a random distance from them.
        i0, i1 = np.sort(rng.integers(0, n, 2))
        j0, j1 = np.sort(rng.integers(0, n, 2))
        offset = rng.uniform(WALKER_CLEARANCE, 0.5 * street - WALKER_CLEARANCE)
        x_lo, x_hi = centres[i0] - 0.5 * size - offset, centres[i1] + 0.5 * size + offset
        z_lo, z_hi = centres[j0] - 0.5 * size - offset, centres[j1] + 0.5 * size + offset
        y = 0.5 * WALKER_HEIGHT
        path = np.array([[x_lo, y, z_lo], [x_hi, y, z_lo], [x_hi, y, z_hi], [x_lo, y, z_hi]])
        if rng.random() < 0.5:
            path = path[::-1]
        path = np.roll(path, int(rng.integers(4)), axis=0)
        speed = rng.uniform(*WALKER_SPEED)
        loop = 2.0 * ((x_hi - x_lo) + (z_hi - z_lo))
        walkers.append(Walker(mesh=walker_mesh.copy(), path=np.ascontiguousarray(path),
                              speed=float(speed), phase=float(rng.uniform(0.0, loop / speed))))
    lamps = _lamps(rng, params, centres) if params.lamps else []
    statics += [post for post, _ in lamps]
    return Town(floors=[floor], statics=statics, walkers=walkers,
                lamps=[lamp for _, lamp in lamps])


def _lamps(rng: np.random.Generator, params: TownParams,
           centres: np.ndarray) -> list[tuple[trimesh.Trimesh, Lamp]]:
    """``params.lamps`` street lamps at places drawn from the blocks' edges: a post just off the
    edge, an arm over the street and the light under its end. Drawn after everything else, so
    a town without lamps is the town it always was."""
    n, size = len(centres), params.block_size
    per_edge = max(2, math.ceil(params.lamps / (4 * n * n)))
    spots = []
    for bx in centres:
        for bz in centres:
            for k in range(per_edge):
                along = (k + 0.5) / per_edge - 0.5
                reach = 0.5 * size + LAMP_SETBACK
                for normal in ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)):
                    tangent = (-normal[1], normal[0])
                    spots.append((bx + normal[0] * reach + tangent[0] * along * size,
                                  bz + normal[1] * reach + tangent[1] * along * size,
                                  *normal))
    chosen = np.sort(rng.choice(len(spots), params.lamps, replace=False))
    templates = _templates(params.detail)
    out = []
    for index in chosen:
        x, z, nx, nz = spots[index]
        out_dir = np.array([nx, 0.0, nz])
        base = np.array([x, 0.0, z])
        post = _place(templates.trunk, (LAMP_POST_RADIUS, LAMP_HEIGHT, LAMP_POST_RADIUS),
                      base + [0.0, 0.5 * LAMP_HEIGHT, 0.0])
        top = base + [0.0, LAMP_HEIGHT, 0.0]
        end = top + out_dir * LAMP_ARM
        half = np.array([0.04, 0.06, 0.04]) * (1.0 - np.abs(out_dir))  # the arm's thickness
        arm = boxes(np.minimum(top, end) - half, np.maximum(top, end) + half)
        head = boxes(end - [LAMP_HEAD[0] / 2, LAMP_HEAD[1], LAMP_HEAD[2] / 2],
                     end + [LAMP_HEAD[0] / 2, 0.0, LAMP_HEAD[2] / 2])
        mesh = _mesh([post, arm, head])
        light = end - [0.0, LAMP_HEAD[1] + LAMP_LIGHT_DROP, 0.0]
        out.append((mesh, Lamp(position=light, cone=params.lamp_cone, range=params.lamp_range)))
    return out
