"""Procedural towns for benchmarks: the ``[generate]`` table of a scene file.

A town is a square grid of ``blocks`` x ``blocks`` city blocks separated by streets, on one floor
that covers it all. Each block is cut into a grid of lots; a random choice of lots holds buildings
(boxes with a cornice, a roof housing and protruding window frames and ledges) and trees (a
cylinder trunk with a sphere or cone crown). Walkers are capsules looping around rectangles of
blocks, in the streets, so they never walk through a static.

Speed matters here: a 1 M-triangle town must build in a few seconds, so every building and tree
is instanced from unit templates with numpy (game/scene/town_shapes.py). Every building and every
tree stays its own mesh, so that each is its own named static object in the scene.

The table's keys, with their defaults, are :class:`TownParams`; docs/scenes.md documents them.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any, NoReturn

import numpy as np
import trimesh

from game.errors import SceneError
from game.scene.shapes import capsule_mesh
from game.scene.town_shapes import (
    BOX_FACES,
    WINDOW_PITCH_AT_DETAIL_0,
    boxes,
    building_mesh,
    mesh_of,
    place,
    templates_for,
    tree_mesh,
)

MIN_STOREYS = 2
LOT_MARGIN = 0.4  # metres kept free between a building's outermost detail and its lot edge
FOOTPRINT_FRACTION = (0.55, 0.8)  # of the lot side, per axis
MIN_LOT_SIDE = 3.0  # metres: room for a small building or tree inside its margins

TREE_CROWN_RADIUS = (1.2, 2.6)  # metres, before clamping to the lot
TREE_TRUNK_HEIGHT = (1.5, 3.0)  # metres
CONIFER_FRACTION = 0.35  # of trees with a cone crown instead of a sphere

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


def triangle_bound(params: TownParams) -> int:
    """An upper bound on the town's static triangles, from the parameters alone: every building
    at the widest footprint and the most storeys, every tree with the larger crown."""
    lot = _lot_side(params)
    pitch = WINDOW_PITCH_AT_DETAIL_0 / (1 + params.detail)
    columns = max(1, int(min(FOOTPRINT_FRACTION[1] * lot, lot - 2.0 * LOT_MARGIN) // pitch))
    storeys = params.max_storeys
    per_building = (3 + (storeys - 1 if params.detail >= 1 else 0)
                    + 4 * columns * storeys * (2 if params.detail >= 2 else 1))
    templates = templates_for(params.detail)
    per_tree = len(templates.trunk[1]) + max(len(templates.sphere[1]), len(templates.cone[1]))
    per_block = (params.buildings_per_block * len(BOX_FACES) * per_building
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
    floor = mesh_of([boxes(np.array([-half_town, -FLOOR_THICKNESS, -half_town]),
                           np.array([half_town, 0.0, half_town]))])

    templates = templates_for(params.detail)
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
                    statics.append(building_mesh(rng, x, z, width, depth, storeys, params.detail))
                else:
                    crown = min(rng.uniform(*TREE_CROWN_RADIUS), 0.5 * lot - LOT_MARGIN)
                    slack = 0.5 * lot - LOT_MARGIN - crown
                    x, z = (lot_x[k], lot_z[k]) + rng.uniform(-1.0, 1.0, 2) * slack
                    trunk = rng.uniform(*TREE_TRUNK_HEIGHT)
                    conifer = bool(rng.random() < CONIFER_FRACTION)
                    statics.append(tree_mesh(templates, x, z, crown, trunk, conifer))

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
    templates = templates_for(params.detail)
    out = []
    for index in chosen:
        x, z, nx, nz = spots[index]
        out_dir = np.array([nx, 0.0, nz])
        base = np.array([x, 0.0, z])
        post = place(templates.trunk, (LAMP_POST_RADIUS, LAMP_HEIGHT, LAMP_POST_RADIUS),
                      base + [0.0, 0.5 * LAMP_HEIGHT, 0.0])
        top = base + [0.0, LAMP_HEIGHT, 0.0]
        end = top + out_dir * LAMP_ARM
        half = np.array([0.04, 0.06, 0.04]) * (1.0 - np.abs(out_dir))  # the arm's thickness
        arm = boxes(np.minimum(top, end) - half, np.maximum(top, end) + half)
        head = boxes(end - [LAMP_HEAD[0] / 2, LAMP_HEAD[1], LAMP_HEAD[2] / 2],
                     end + [LAMP_HEAD[0] / 2, 0.0, LAMP_HEAD[2] / 2])
        mesh = mesh_of([post, arm, head])
        light = end - [0.0, LAMP_HEAD[1] + LAMP_LIGHT_DROP, 0.0]
        out.append((mesh, Lamp(position=light, cone=params.lamp_cone, range=params.lamp_range)))
    return out
