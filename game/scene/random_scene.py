"""Seeded random scenes for accuracy sweeps: ``python -m game scenes random --seed N``.

The project's own scenes were tuned while the methods were; a scene drawn at random says
whether the accuracy holds elsewhere. A draw varies what real scenes vary: crowds of 0 to
MAX_WALKERS walkers (capsules and the real corpus's meshes), statics of every shape the loader
knows, real props, stacked and touching objects, rotated and scaled, a large tilted box, at times
a one-file level of the real corpus; a sun from 5 to 85 degrees of elevation, spot and point
lamps among the casters, up to MAX_LIGHTS lights; a camera at street level or far above; and the
picture size it is meant for.

The draw uses Python's ``random.Random``, whose stream for an integer seed is the same on every
platform and Python version, and writes every number with fixed decimals: the same seed always
gives the same bytes. :func:`draw` reads only the real corpus (assets/real, fetched by
assets/fetch_real.py); :func:`scene_files` returns the scene file and copies of the meshes it
names, so that the folder they are written to reads nothing outside itself.
"""

from __future__ import annotations

import functools
import math
import random
import tomllib
import warnings
from dataclasses import dataclass
from typing import NoReturn

from game.data import ASSET_DIR
from game.errors import GameError
from game.scene.mesh_files import load_mesh_file
from game.scene.random_parts import (
    DECIMALS,
    Box,
    LightPart,
    MeshFile,
    Placed,
    Point,
    Round,
    Shape,
    Sphere,
    Spot,
    Sun,
    View,
    Walker,
    vec,
)

REAL_DIR = ASSET_DIR / "real"
PROPS = ("duck.obj", "bunny.obj", "teddy2_VHACD_CHs.obj", "teapot.obj")
WALKER_MESHES = ("duck.obj", "bunny.obj", "teddy2_VHACD_CHs.obj")
LEVEL_SCENE = "monastery.toml"   # the one-file level: its floors, and the mesh it names
SIZES = ((320, 180), (960, 540))
LEVEL_SHARE = 0.15               # of scenes built around the level
MAX_WALKERS = 256
MAX_MESH_WALKERS = 48            # mesh walkers are 1-4 k triangles each; capsules are light
NO_CROWD_SHARE = 0.15
MAX_LIGHTS = 4
SUN_ELEVATION = (5.0, 85.0)      # degrees
PLAZA_HALF = (8.0, 40.0)         # metres, half the side of the walked square
FLOOR_MARGIN = 10.0              # metres of floor beyond the plaza on every side
FLOOR_THICKNESS = 0.2
MAX_GROUPS_PER_METRE = 0.8       # static groups per metre of the plaza's half side
CAPSULE_RADIUS = (0.22, 0.35)
CAPSULE_HEIGHT = (1.5, 1.95)
MESH_WALKER_HEIGHT = (0.5, 1.6)
WALK_SPEED = (0.5, 2.0)          # metres per second
MIN_LOOP = 0.1                   # metres: a shorter loop stands still
PROP_HEIGHT = (0.3, 3.0)
STREET_EYE = (1.4, 2.2)          # metres above the floor
HIGH_EYE = (15.0, 80.0)
FOV = (40.0, 75.0)
SPOT_CONE = (30.0, 150.0)


@dataclass(frozen=True)
class RandomScene:
    """One drawn scene: its file's text, the corpus files it names, the size it is drawn for."""

    seed: int
    name: str
    size: tuple[int, int]
    text: str
    meshes: tuple[str, ...]
    summary: str

    @property
    def file_name(self) -> str:
        return f"{self.name}.toml"


def draw(seed: int) -> RandomScene:
    """The scene of ``seed``; GameError (one line) where the real corpus is missing."""
    if not 0 <= seed < 2**63:
        raise GameError(f"--seed {seed}: must be 0..{2**63 - 1}")
    missing = [f for f in (*PROPS, LEVEL_SCENE) if not (REAL_DIR / f).is_file()]
    if missing:
        raise GameError(f"random scenes use the real corpus, and {REAL_DIR} lacks "
                        f"{', '.join(missing)}: python assets/fetch_real.py fetches it")
    rng = random.Random(seed)
    draft = _Draft(rng)
    if rng.random() < LEVEL_SHARE:
        draft.level()
    else:
        draft.plaza()
    draft.add_statics()
    draft.add_crowd()
    draft.add_lights()
    draft.add_camera()
    size = rng.choice(SIZES)
    return draft.finish(seed, size)


def scene_files(scene: RandomScene) -> dict[str, bytes]:
    """The files of the scene's folder, by name: the scene file and its meshes' copies."""
    files = {scene.file_name: scene.text.encode("utf-8")}
    for name in scene.meshes:
        files[name] = (REAL_DIR / name).read_bytes()
    return files


@functools.cache
def _bounds(name: str) -> MeshFile:
    """A corpus mesh's bounds, as the loader reads it."""
    def fail(problem: str) -> NoReturn:
        raise GameError(f"{REAL_DIR / name}: {problem}")

    with warnings.catch_warnings():  # the loader says it again when the scene is read
        warnings.simplefilter("ignore")
        mesh = load_mesh_file(name, REAL_DIR, str(REAL_DIR / name), fail)
    low, high = mesh.bounds
    return MeshFile(name, tuple(float(x) for x in low), tuple(float(x) for x in high))


class _Draft:
    """A scene being drawn, part by part, from one random stream (the order of the draws is
    part of what a seed means: change it and every seed gives another scene)."""

    def __init__(self, rng: random.Random):
        self.rng = rng
        self.floors: list[Placed] = []
        self.statics: list[Placed] = []
        self.walkers: list[Walker] = []
        self.lamps: list[LightPart] = []
        self.view: View | None = None
        self.meshes: dict[str, None] = {}
        self.half = 0.0          # half side of the square that walkers and statics use
        self.ground = 0.0        # the floor's top where they stand
        self.inner = 0.0         # half side kept clear (the level's compound), 0 on a plaza
        self.level_name = ""

    def uniform(self, pair: tuple[float, float]) -> float:
        return self.rng.uniform(*pair)

    def spot_xz(self) -> tuple[float, float]:
        """A point of the walked ground: the plaza, or the ring around the level."""
        while True:
            x, z = (self.rng.uniform(-self.half, self.half) for _ in range(2))
            if max(abs(x), abs(z)) >= self.inner:
                return x, z

    # -- ground -------------------------------------------------------------------------------
    def plaza(self) -> None:
        self.half = self.uniform(PLAZA_HALF)
        side = 2 * (self.half + FLOOR_MARGIN)
        self.floors.append(Placed(Box((side, FLOOR_THICKNESS, side)),
                                  (0.0, -FLOOR_THICKNESS / 2, 0.0)))

    def level(self) -> None:
        """The real corpus's one-file level on its own ground, walked around its walls."""
        text = (REAL_DIR / LEVEL_SCENE).read_text(encoding="utf-8")
        data = tomllib.loads(text)
        static = data["static"][0]
        mesh = _bounds(static["file"])
        self.meshes[mesh.file] = None
        tops = []
        for floor in data.get("floor", []):
            size, pos = floor["size"], floor["position"]
            self.floors.append(Placed(Box(tuple(size)), tuple(pos)))
            tops.append(pos[1] + size[1] / 2)
        self.statics.append(Placed(mesh, (0.0, 0.0, 0.0), note="the level"))
        self.ground = max(tops)
        self.inner = max(abs(c) for c in (*mesh.low[::2], *mesh.high[::2])) + 2.0
        self.half = self.inner + self.uniform((15.0, 40.0))
        self.level_name = data.get("name", LEVEL_SCENE)

    # -- statics ------------------------------------------------------------------------------
    def shape(self) -> tuple[Shape, float | tuple[float, float, float]]:
        """A random shape of any kind the loader knows, and its scale."""
        rng = self.rng
        kind = rng.choice(("box", "box", "sphere", "cylinder", "capsule", "cone", "prop"))
        if kind == "prop":
            mesh = _bounds(rng.choice(PROPS))
            self.meshes[mesh.file] = None
            return mesh, self.uniform(PROP_HEIGHT) / mesh.tallness
        if kind == "box":
            shape: Shape = Box(tuple(rng.uniform(0.3, 4.0) for _ in range(3)))
        elif kind == "sphere":
            shape = Sphere(rng.uniform(0.2, 1.8))
        else:
            shape = _round(kind, rng.uniform(0.15, 1.2), rng.uniform(0.4, 4.0))
        if rng.random() < 0.3:
            return shape, tuple(rng.uniform(0.5, 1.8) for _ in range(3))
        return shape, 1.0

    def stand(self, shape: Shape, scale, x: float, z: float, base: float,
              yaw: float, note: str = "") -> Placed:
        """``shape`` standing on height ``base`` at (x, z), turned by ``yaw`` about Y."""
        sy = scale[1] if isinstance(scale, tuple) else scale
        if isinstance(shape, MeshFile):
            y = base - shape.low[1] * sy
        else:
            y = base + shape.half_height() * sy
        placed = Placed(shape, (x, y, z), (0.0, yaw, 0.0), scale, note)
        self.statics.append(placed)
        return placed

    def add_statics(self) -> None:
        rng = self.rng
        groups = rng.randint(0, int(MAX_GROUPS_PER_METRE * self.half))
        for _ in range(groups):
            x, z = self.spot_xz()
            yaw = rng.uniform(0.0, 360.0)
            kind = rng.choice(("single", "single", "stack", "touching", "tilted"))
            if kind == "tilted":
                size = (rng.uniform(3.0, 9.0), rng.uniform(2.0, 6.0), rng.uniform(0.3, 2.0))
                tilt = (rng.uniform(-50.0, 50.0), yaw, rng.uniform(-50.0, 50.0))
                centre = (x, self.ground + rng.uniform(0.3, 0.6) * size[1], z)
                self.statics.append(Placed(Box(size), centre, tilt, note="a large tilted box"))
            elif kind == "stack":
                base = Box((rng.uniform(1.0, 3.0), rng.uniform(0.5, 2.0), rng.uniform(1.0, 3.0)))
                self.stand(base, 1.0, x, z, self.ground, yaw, "a stack")
                top = self.ground + base.size[1]
                for _ in range(rng.randint(1, 2)):
                    shape, scale = self.shape()
                    placed = self.stand(shape, scale, x + rng.uniform(-0.3, 0.3),
                                        z + rng.uniform(-0.3, 0.3), top, rng.uniform(0, 360))
                    top = _top(placed, top)
            elif kind == "touching":
                a = Box((rng.uniform(0.8, 3.0), rng.uniform(0.5, 3.0), rng.uniform(0.8, 3.0)))
                b = Box((rng.uniform(0.8, 3.0), rng.uniform(0.5, 3.0), a.size[2]))
                self.stand(a, 1.0, x, z, self.ground, 0.0, "two boxes touching")
                self.stand(b, 1.0, x + (a.size[0] + b.size[0]) / 2, z, self.ground, 0.0)
            else:
                shape, scale = self.shape()
                self.stand(shape, scale, x, z, self.ground, yaw)

    # -- walkers ------------------------------------------------------------------------------
    def add_crowd(self) -> None:
        rng = self.rng
        if rng.random() < NO_CROWD_SHARE:
            return
        count = min(MAX_WALKERS, int(math.exp(rng.uniform(0.0, math.log(MAX_WALKERS + 1)))))
        mesh_share = rng.choice((0.0, 0.0, 0.25, 0.5))
        dense = rng.random() < 0.5   # a packed crowd: walkers in each other's shadows
        centre = self.spot_xz()
        spread = max(2.0, 0.9 * math.sqrt(count)) if dense else self.half
        mesh_walkers = 0
        for _ in range(count):
            if rng.random() < mesh_share and mesh_walkers < MAX_MESH_WALKERS:
                mesh_walkers += 1
                mesh = _bounds(rng.choice(WALKER_MESHES))
                self.meshes[mesh.file] = None
                scale = self.uniform(MESH_WALKER_HEIGHT) / mesh.tallness
                shape: Shape = mesh
                y = self.ground - mesh.low[1] * scale
            else:
                shape = _round("capsule", self.uniform(CAPSULE_RADIUS),
                               self.uniform(CAPSULE_HEIGHT))
                scale, y = 1.0, self.ground + shape.half_height()
            path = self.path(centre, spread, y)
            self.walkers.append(Walker(shape, path, self.uniform(WALK_SPEED),
                                       rng.uniform(0.0, 30.0), scale))

    def path(self, centre, spread: float, y: float) -> tuple[tuple[float, float, float], ...]:
        """A closed loop near ``centre``: a rectangle, a back-and-forth line, a polygon, or a
        standing point."""
        rng = self.rng
        limit = self.half

        def at(dx: float, dz: float) -> tuple[float, float, float]:
            return (max(-limit, min(limit, centre[0] + dx)), y,
                    max(-limit, min(limit, centre[1] + dz)))

        ox, oz = (rng.uniform(-spread, spread) for _ in range(2))
        kind = rng.choice(("rectangle", "line", "polygon", "polygon", "stand"))
        if kind == "line":
            dx, dz = (rng.uniform(-spread, spread) / 2 for _ in range(2))
            loop = at(ox - dx, oz - dz), at(ox + dx, oz + dz)
        elif kind == "rectangle":
            w, d = (rng.uniform(0.5, max(1.0, spread / 2)) for _ in range(2))
            loop = at(ox - w, oz - d), at(ox + w, oz - d), at(ox + w, oz + d), at(ox - w, oz + d)
        elif kind == "polygon":
            radius = rng.uniform(0.5, max(1.0, spread / 3))
            n = rng.randint(3, 7)
            loop = tuple(at(ox + radius * math.cos(2 * math.pi * k / n),
                            oz + radius * math.sin(2 * math.pi * k / n)) for k in range(n))
        else:
            loop = ()
        # A loop squeezed into the plaza's corner can shrink to a point: it stands there.
        if sum(math.dist(p, q) for p, q in zip(loop, loop[1:] + loop[:1], strict=True)) < MIN_LOOP:
            return (at(ox, oz),)
        return loop

    # -- lights and camera --------------------------------------------------------------------
    def add_lights(self) -> None:
        rng = self.rng
        count = rng.choice((1, 1, 1, 2, 2, 3, MAX_LIGHTS))
        first = rng.choice(("sun", "sun", "sun", "spot", "point"))
        for k in range(count):
            kind = first if k == 0 else rng.choice(("spot", "point"))
            warm = (1.0, rng.uniform(0.75, 1.0), rng.uniform(0.5, 1.0))
            if kind == "sun":
                self.lamps.append(Sun(self.uniform(SUN_ELEVATION), rng.uniform(0.0, 360.0),
                                      warm, rng.uniform(0.7, 1.3)))
                continue
            position = self.lamp_position()
            reach = rng.uniform(0.6, 3.0) * self.half if rng.random() < 0.5 else None
            if kind == "point":
                self.lamps.append(Point(position, reach, warm, rng.uniform(0.8, 2.0)))
                continue
            aim_x, aim_z = self.spot_xz()
            direction = (aim_x - position[0], self.ground - position[1], aim_z - position[2])
            if math.dist(direction, (0.0, 0.0, 0.0)) < 0.5:
                direction = (0.0, -1.0, 0.0)
            self.lamps.append(Spot(position, direction, self.uniform(SPOT_CONE), reach, warm,
                                   rng.uniform(0.8, 2.0)))

    def lamp_position(self) -> tuple[float, float, float]:
        """Beside a static (among the casters) where there is one, else anywhere above."""
        rng = self.rng
        if self.statics and rng.random() < 0.6:
            near = rng.choice(self.statics)
            x, _, z = near.position
            reach = near.shape.half_width() + rng.uniform(0.5, 3.0)
            a = rng.uniform(0.0, 2 * math.pi)
            return (x + reach * math.cos(a), self.ground + rng.uniform(1.0, 6.0),
                    z + reach * math.sin(a))
        x, z = self.spot_xz()
        return x, self.ground + rng.uniform(2.0, 12.0), z

    def add_camera(self) -> None:
        rng = self.rng
        a = rng.uniform(0.0, 2 * math.pi)
        fov = self.uniform(FOV)
        if rng.random() < 0.5:
            eye = self.ground + self.uniform(STREET_EYE)
            r = rng.uniform(0.6, 1.1) * self.half
            b = a + math.pi + rng.uniform(-0.6, 0.6)
            position = (r * math.cos(a), eye, r * math.sin(a))
            target = (0.5 * self.half * math.cos(b), self.ground + 1.0,
                      0.5 * self.half * math.sin(b))
            self.view = View(position, target, fov, 0.1, 4 * self.half + 60.0, True)
            return
        height = self.uniform(HIGH_EYE) + self.ground
        r = rng.uniform(0.3, 1.5) * self.half
        position = (r * math.cos(a), height, r * math.sin(a))
        target = (rng.uniform(-0.3, 0.3) * self.half, self.ground,
                  rng.uniform(-0.3, 0.3) * self.half)
        far = math.dist(position, target) + 3 * self.half + 60.0
        self.view = View(position, target, fov, 0.5, far, False)

    # -- the file -----------------------------------------------------------------------------
    def finish(self, seed: int, size: tuple[int, int]) -> RandomScene:
        name = f"random_{seed}"
        kinds = [type(lamp).__name__.lower() for lamp in self.lamps]
        walkers_mesh = sum(isinstance(w.shape, MeshFile) for w in self.walkers)
        summary = (f"{'the ' + self.level_name + ' level, ' if self.level_name else ''}"
                   f"{len(self.statics)} statics, {len(self.walkers)} walkers "
                   f"({walkers_mesh} meshes), lights: {', '.join(kinds)}, camera "
                   f"{'at street level' if self.view.street else 'far above'}, for "
                   f"{size[0]}x{size[1]}")
        high = self.ground + 30.0
        lines = [f"# A random scene: python -m game scenes random --seed {seed}",
                 f"# {summary}", f'name = "{name}"', "", *self.view.table(), ""]
        for lamp in self.lamps:
            lines += [*lamp.table(), ""]
        lines += ["[linear_light]", f"a = {vec((-self.half / 2, high, 0.0))}",
                  f"b = {vec((self.half / 2, high, 0.0))}", ""]
        for floor in self.floors:
            lines += [*floor.table("floor"), ""]
        for static in self.statics:
            lines += [*static.table("static"), ""]
        for walker in self.walkers:
            lines += [*walker.table(), ""]
        return RandomScene(seed, name, size, "\n".join(lines), tuple(self.meshes), summary)


def _round(kind: str, radius: float, height: float) -> Round:
    """A cylinder, capsule or cone as it will be written; a capsule at least as tall as its
    caps."""
    radius, height = round(radius, DECIMALS), round(height, DECIMALS)
    return Round(kind, radius, max(height, 2 * radius) if kind == "capsule" else height)


def _top(placed: Placed, base: float) -> float:
    """The height of the top of an object stood on ``base`` (for stacking the next one)."""
    sy = placed.scale[1] if isinstance(placed.scale, tuple) else placed.scale
    shape = placed.shape
    tall = shape.tallness if isinstance(shape, MeshFile) else 2 * shape.half_height()
    return base + tall * sy

