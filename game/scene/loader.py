"""The scene file's loader: TOML text in, a validated :class:`~game.scene.model.Scene` out.

The format is docs/reference.md's section 1. Every error is a :class:`~game.errors.SceneError`
with a one-line message of the form ``<file>:<line>: <table>.<key>: <problem>``.

Extensions to the format (docs/scenes.md): characters take optional ``rotation`` and ``scale``
keys, applied in local space before the walking yaw, and a ``[generate]`` table adds a
procedural town (:mod:`game.scene.generate`) after the objects listed in the file.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import trimesh

from game.data import ASSET_DIR
from game.errors import SceneError
from game.scene.budget import DrawBudget
from game.scene.mesh_files import open_regular
from game.scene.model import (
    DEFAULT_FAR,
    DEFAULT_FOV_DEG,
    DEFAULT_NEAR,
    DEFAULT_SPEED,
    LIGHT_KINDS,
    Body,
    Camera,
    Character,
    Light,
    LinearLight,
    Scene,
)
from game.scene.shapes import (
    box_mesh,
    capsule_mesh,
    cone_mesh,
    cylinder_mesh,
    sphere_mesh,
    transform_mesh,
)
from game.scene.toml_tables import MAX_MAGNITUDE, Context, Table, describe, is_number, suggest
from game.transforms import euler_xyz

# Keys each shape needs; a key of another shape is an error, not silently ignored.
SHAPE_KEYS: dict[str, tuple[str, ...]] = {
    "box": ("size",),
    "sphere": ("radius",),
    "cylinder": ("radius", "height"),
    "capsule": ("radius", "height"),
    "cone": ("radius", "height"),
    "mesh": ("file",),
}
ALL_SHAPE_KEYS = tuple(sorted({k for keys in SHAPE_KEYS.values() for k in keys}))
MAX_SCENE_BYTES = 4 * 2**20   # a scene file; its meshes live in their own files
MAX_FAR_OVER_NEAR = 1e7

TOP_LEVEL_KEYS = ("name", "camera", "light", "linear_light", "floor", "static", "character",
                  "generate")
CAMERA_KEYS = ("position", "target", "fov", "near", "far")
LIGHT_KEYS: dict[str, tuple[str, ...]] = {   # besides kind, color and intensity
    "directional": ("direction",),
    "spot": ("direction", "position", "cone", "range"),
    "point": ("position", "range"),
}
# Every light's maps share one depth array and one shadow budget; the shading pass's light
# records are a uniform block.
MAX_LIGHTS = 64
# Each character gets its own shadow map and walks every frame: as many as a [generate] town
# may have walkers (game/scene/generate.py), checked before any of them is built.
MAX_CHARACTERS = 4096
LINEAR_LIGHT_KEYS = ("a", "b")
BODY_KEYS = ("shape", "position", "rotation", "scale", "color")
CHARACTER_KEYS = ("shape", "path", "speed", "phase", "rotation", "scale", "color")

def _shape_mesh(table: Table, extra_keys: Iterable[str], budget: DrawBudget) -> trimesh.Trimesh:
    """The local mesh of a floor, static or character table, checking its keys; a mesh file
    whose count is known passes the scene's budget before it is read."""
    shape = table.string("shape", choices=list(SHAPE_KEYS))
    own = SHAPE_KEYS[shape]
    misplaced = {k: f"not a key of shape '{shape}' ({shape} takes: {', '.join(own)})"
                 for k in ALL_SHAPE_KEYS if k not in own}
    table.check_keys([*extra_keys, *own], misplaced)
    if shape == "box":
        return box_mesh(table.lengths("size"))
    if shape == "sphere":
        return sphere_mesh(table.length("radius"))
    if shape == "mesh":
        return _mesh_file(table, budget)
    radius = table.length("radius")
    height = table.length("height")
    if shape == "cylinder":
        return cylinder_mesh(radius, height)
    if shape == "cone":
        return cone_mesh(radius, height)
    if height < 2.0 * radius:
        table.fail("height", f"a capsule's total height must be at least 2 * radius "
                             f"({2.0 * radius:g}), got {height:g}")
    return capsule_mesh(radius, height)


def _mesh_file(table: Table, budget: DrawBudget) -> trimesh.Trimesh:
    relative = table.require("file")
    if not isinstance(relative, str):
        table.fail("file", f"must be a string, got {describe(relative)}")

    def fail(problem: str) -> NoReturn:
        table.fail("file", problem)

    return budget.mesh_file(relative, table.ctx.base_dir, table.ctx.label, fail)


def _count(table: Table, mesh: trimesh.Trimesh, budget: DrawBudget) -> None:
    """Count what an entry draws towards the scene's total."""

    def fail(problem: str) -> NoReturn:
        table.fail("file" if table.has("file") else "shape", problem)

    budget.add(len(mesh.faces), len(mesh.vertices), fail)


# --------------------------------------------------------------------------------------------
# Tables


def _parse_camera(ctx: Context, data: Any) -> Camera:
    table = Table(ctx, "camera", None, data)
    table.check_keys(CAMERA_KEYS)
    position = table.vec3("position")
    target = table.vec3("target")
    if np.allclose(position, target):
        table.fail("target", "must differ from camera.position")
    fov = table.number("fov", DEFAULT_FOV_DEG, positive=True, below=180.0)
    near = table.number("near", DEFAULT_NEAR, positive=True)
    far = table.number("far", DEFAULT_FAR, positive=True)
    if near >= far:
        table.fail("far" if table.has("far") else "near",
                   f"near ({near:g}) must be less than far ({far:g})")
    if far / near > MAX_FAR_OVER_NEAR:
        # A float32 depth buffer cannot tell surfaces apart beyond this ratio.
        table.fail("near" if table.has("near") else "far",
                   f"far / near is {far / near:.3g}; at most {MAX_FAR_OVER_NEAR:.0e} (raise near)")
    return Camera(position=position, target=target, fov=fov, near=near, far=far)


def _parse_lights(ctx: Context, data: Any) -> list[Light]:
    """One ``[light]`` table, or a ``[[light]]`` array of one or more."""
    if isinstance(data, list):
        if not data:
            ctx.fail("light", None, None, "a [[light]] array needs at least one light")
        if len(data) > MAX_LIGHTS:
            ctx.fail("light", MAX_LIGHTS, None,
                     f"at most {MAX_LIGHTS} lights, got {len(data)}")
        return [_parse_light(Table(ctx, "light", i, d)) for i, d in enumerate(data)]
    return [_parse_light(Table(ctx, "light", None, data))]


def _parse_light(table: Table) -> Light:
    kind = table.string("kind", LIGHT_KINDS)
    needed = LIGHT_KEYS[kind]
    misplaced = {k: f"not used by a '{kind}' light ({kind} takes: {', '.join(needed)})"
                 for k in ("direction", "position", "cone", "range") if k not in needed}
    table.check_keys(("kind", "color", "intensity", *needed), misplaced)
    direction = position = cone = light_range = None
    if "direction" in needed:
        direction = table.vec3("direction")
        norm = float(np.linalg.norm(direction))
        if norm < 1e-12:
            table.fail("direction", f"must not be zero, got {table.data['direction']}")
        direction = direction / norm
    if "position" in needed:
        position = table.vec3("position")
    if "cone" in needed:
        cone = table.number("cone", positive=True, below=180.0)
    if "range" in needed and table.has("range"):
        light_range = table.number("range", positive=True)
    colour = _colour(table)
    return Light(kind=kind, direction=direction, position=position, cone=cone,
                 color=(1.0, 1.0, 1.0) if colour is None else tuple(float(c) for c in colour),
                 intensity=table.number("intensity", 1.0, non_negative=True),
                 range=light_range)


def _parse_linear_light(ctx: Context, data: Any) -> LinearLight:
    table = Table(ctx, "linear_light", None, data)
    table.check_keys(LINEAR_LIGHT_KEYS)
    a, b = table.vec3("a"), table.vec3("b")
    if np.allclose(a, b):
        table.fail("b", f"the segment is {float(np.linalg.norm(b - a)):.3g} m long; a light "
                        "segment needs a and b apart")
    return LinearLight(a=a, b=b)


def _entries(ctx: Context, data: dict[str, Any], kind: str) -> list[Any]:
    """The entries of an array of tables ``[[kind]]``."""
    value = data.get(kind, [])
    if not isinstance(value, list):
        ctx.fail(kind, None, None, f"must be an array of tables, write [[{kind}]]")
    return value


def _parse_body(ctx: Context, kind: str, index: int, data: Any, budget: DrawBudget) -> Body:
    table = Table(ctx, kind, index, data)
    local = _shape_mesh(table, BODY_KEYS, budget)
    position = table.vec3("position", (0.0, 0.0, 0.0))
    rotation = table.vec3("rotation", (0.0, 0.0, 0.0))
    scale = table.scale()
    linear = euler_xyz(rotation) @ np.diag(scale)
    mesh = transform_mesh(local, linear, position)
    _check_extent(table, mesh)
    _count(table, mesh, budget)
    return Body(name=f"{kind}_{index}", kind=kind, mesh=mesh, colour=_colour(table))


def _check_extent(table: Table, mesh) -> None:
    """World-space vertices within the format's magnitude, after scale and rotation: their
    float32 form stays finite and keeps its precision."""
    reach = float(np.abs(mesh.vertices).max())
    if not reach <= MAX_MAGNITUDE:
        key = "scale" if table.has("scale") else ("file" if table.has("file") else None)
        table.fail(key, f"places vertices {reach:.3g} m from the origin; at most "
                        f"{MAX_MAGNITUDE:g} m")


def _parse_path(table: Table) -> np.ndarray:
    value = table.require("path")
    if not isinstance(value, list) or not value:
        table.fail("path", f"must be a non-empty list of [x, y, z] points, got "
                           f"{describe(value)}")
    points = np.array([_point(table, i, p) for i, p in enumerate(value)])
    if len(points) > 1:
        loop = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum()
        if loop <= 0.0:
            table.fail("path", "the loop has zero length (every point is the same)")
    return points


def _point(table: Table, i: int, value: Any) -> np.ndarray:
    if (not isinstance(value, list) or len(value) != 3
            or not all(is_number(v) for v in value)):
        table.fail("path", f"point {i} must be a list of 3 numbers [x, y, z], got "
                           f"{describe(value)}")
    if not all(isinstance(v, int) or math.isfinite(v) for v in value):
        table.fail("path", f"point {i} must be finite, got {value}")
    if not all(abs(v) <= MAX_MAGNITUDE for v in value):
        table.fail("path", f"point {i} must be within +-{MAX_MAGNITUDE:g}, got {describe(value)}")
    return np.array(value, dtype=np.float64)


def _parse_character(ctx: Context, index: int, data: Any, budget: DrawBudget) -> Character:
    table = Table(ctx, "character", index, data)
    local = _shape_mesh(table, CHARACTER_KEYS, budget)
    path = _parse_path(table)
    speed = table.number("speed", DEFAULT_SPEED, non_negative=True)
    phase = table.number("phase", 0.0)
    rotation = table.vec3("rotation", (0.0, 0.0, 0.0))
    scale = table.scale()
    mesh = transform_mesh(local, euler_xyz(rotation) @ np.diag(scale))
    _check_extent(table, mesh)
    _count(table, mesh, budget)
    return Character(name=f"character_{index}", mesh=mesh, path=path, speed=speed, phase=phase,
                     colour=_colour(table))


def _colour(table: Table) -> np.ndarray | None:
    """The optional ``color``: three sRGB components in [0, 1]; None when not given."""
    if not table.has("color"):
        return None
    colour = table.vec3("color")
    if np.any(colour < 0.0) or np.any(colour > 1.0):
        table.fail("color", f"must be three numbers in [0, 1] (sRGB), got "
                            f"{describe(table.data['color'])}")
    return colour


def _add_generated(ctx: Context, data: Any, floors: list[Body], statics: list[Body],
                   characters: list[Character], lights: list[Light], budget: DrawBudget) -> None:
    """Append the procedural town of a ``[generate]`` table, continuing the numbering; its
    street lamps' lights follow the file's lights. The town counts towards the scene's total
    once it is built (its own limit bounds what building it takes)."""
    # Imported here: the generator builds its shapes with this module's helpers.
    from game.scene import generate

    table = Table(ctx, "generate", None, data)
    params = generate.town_params(table.data, table.fail)
    if len(lights) + params.lamps > MAX_LIGHTS:
        table.fail("lamps", f"{params.lamps} lamps and the file's {len(lights)} light(s) make "
                            f"more than the {MAX_LIGHTS} lights a scene may have")
    town = generate.generate_town(params)
    meshes = [*town.floors, *town.statics, *(walker.mesh for walker in town.walkers)]
    budget.add(sum(len(m.faces) for m in meshes), sum(len(m.vertices) for m in meshes),
               lambda problem: table.fail(None, f"its town {problem}"))
    for mesh in town.floors:
        floors.append(Body(name=f"floor_{len(floors)}", kind="floor", mesh=mesh))
    for mesh in town.statics:
        statics.append(Body(name=f"static_{len(statics)}", kind="static", mesh=mesh))
    for walker in town.walkers:
        characters.append(Character(name=f"character_{len(characters)}", mesh=walker.mesh,
                                    path=walker.path, speed=walker.speed, phase=walker.phase))
    for lamp in town.lamps:
        spot = lamp.cone > 0.0
        lights.append(Light(kind="spot" if spot else "point",
                            direction=np.array([0.0, -1.0, 0.0]) if spot else None,
                            position=lamp.position, cone=lamp.cone if spot else None,
                            color=generate.LAMP_COLOUR, intensity=generate.LAMP_INTENSITY,
                            range=lamp.range))


# --------------------------------------------------------------------------------------------
# Entry points


def parse_scene(text: str, source: Path | None = None, base_dir: Path | None = None) -> Scene:
    """Parse and validate scene TOML.

    Parameters
    ----------
    text
        The TOML text.
    source
        The file it came from, used in messages and kept on the scene; None for in-memory text.
    base_dir
        The folder mesh paths are relative to (and may not leave); defaults to the folder of
        ``source``, or the working directory.

    Raises
    ------
    SceneError
        With a one-line ``<file>:<line>: <table>.<key>: <problem>`` message.
    """
    source = Path(source) if source is not None else None
    if base_dir is None:
        base_dir = source.parent if source is not None else Path.cwd()
    ctx = Context(text, source, Path(base_dir))
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise SceneError(f"{ctx.label}:1: TOML nests too deeply to read") from None
    except tomllib.TOMLDecodeError as error:
        message = str(error)
        match = re.search(r"at line (\d+)", message)
        line = int(match.group(1)) if match else max(len(text.splitlines()), 1)
        if _both_light_forms(text):
            raise SceneError(f"{ctx.label}:{line}: light: a scene has either one [light] table "
                             "or a [[light]] array, not both") from None
        raise SceneError(f"{ctx.label}:{line}: TOML syntax error: {message}") from None
    except ValueError:  # an integer of more digits than Python converts
        raise SceneError(f"{ctx.label}:1: a number too long to read") from None

    for key in data:
        if key not in TOP_LEVEL_KEYS:
            line = ctx.locator.line(key)  # its [header], else its `key =` line
            raise SceneError(f"{ctx.label}:{line}: {key}: unknown key"
                             + suggest(key, TOP_LEVEL_KEYS))
    name = data.get("name", source.stem if source is not None else "scene")
    if not isinstance(name, str):
        ctx.fail(None, None, "name", f"must be a string, got {describe(name)}")
    for required in ("camera", "light"):
        if required not in data:
            raise SceneError(f"{ctx.label}:1: {required}: missing required table [{required}]")

    camera = _parse_camera(ctx, data["camera"])
    lights = _parse_lights(ctx, data["light"])
    linear_light = (_parse_linear_light(ctx, data["linear_light"])
                    if "linear_light" in data else None)
    written = _entries(ctx, data, "character")
    if len(written) > MAX_CHARACTERS:
        ctx.fail("character", MAX_CHARACTERS, None,
                 f"at most {MAX_CHARACTERS:,} characters, got {len(written):,} (a [generate] "
                 "town's walkers are counted apart)")
    budget = DrawBudget()
    budget.count_ahead(data, ctx.base_dir, ctx.fail)
    floors = [_parse_body(ctx, "floor", i, d, budget)
              for i, d in enumerate(_entries(ctx, data, "floor"))]
    statics = [_parse_body(ctx, "static", i, d, budget)
               for i, d in enumerate(_entries(ctx, data, "static"))]
    characters = [_parse_character(ctx, i, d, budget) for i, d in enumerate(written)]
    if "generate" in data:
        _add_generated(ctx, data["generate"], floors, statics, characters, lights, budget)
    return Scene(name=name, source=source, camera=camera, lights=lights, linear_light=linear_light,
                 floors=floors, statics=statics, characters=characters,
                 sha256=hashlib.sha256(text.encode("utf-8")).hexdigest())


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; raises SceneError with a one-line message."""
    path = Path(path)

    def fail(problem: str) -> NoReturn:
        raise SceneError(problem)

    try:
        with open_regular(path, str(path), fail) as f:
            raw = f.read(MAX_SCENE_BYTES + 1)
    except OSError as error:
        raise SceneError(f"cannot read {path}: {error.strerror or error}") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise SceneError(f"{path}: larger than the {MAX_SCENE_BYTES // 2**20} MiB a scene file "
                         "may be (meshes belong in mesh files)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw[: error.start].count(b"\n") + 1
        raise SceneError(f"{path}:{line}: not a UTF-8 text file") from None
    return parse_scene(text, source=path, base_dir=path.parent)


def default_scene_path() -> Path:
    """The built-in scene, assets/default.toml: the town square that ``python -m game`` opens
    and every command takes without a SCENE."""
    return ASSET_DIR / "default.toml"


def _both_light_forms(text: str) -> bool:
    """Whether ``text`` has both a ``[light]`` table and a ``[[light]]`` array, which TOML
    refuses in words of its own ("Cannot overwrite a value")."""
    return (re.search(r"^\s*\[\s*light\s*\]", text, re.M) is not None
            and re.search(r"^\s*\[\[\s*light\s*\]\]", text, re.M) is not None)


def reference_scene_path() -> Path:
    """The courtyard, assets/courtyard.toml: the scene the benchmark, the soft sweep and the GPU
    suite measure beside the towns, and the one docs/results.md gives figures for."""
    return ASSET_DIR / "courtyard.toml"
