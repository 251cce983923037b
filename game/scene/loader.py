"""The scene model and its TOML loader (CONTRACT.md section 1).

A scene file becomes a :class:`Scene`: one camera, one hard-shadow light, an optional linear light,
and three kinds of rigid objects. Floors and statics are stored in world space, so nothing
downstream needs their transforms; characters keep a local mesh and are placed every frame by
:meth:`Character.model_matrix`.

Every error is a :class:`~game.errors.SceneError` with a one-line message of the form
``<file>:<line>: <table>.<key>: <problem>``. ``tomllib`` keeps no positions, so
:class:`_Locator` finds the line of a table or key by scanning the raw text.

Extensions to the contract (documented in docs/scenes.md): characters take optional ``rotation``
and ``scale`` keys, applied in local space before the walking yaw, and a ``[generate]`` table adds
a procedural town (:mod:`game.generate`) after the objects listed in the file.
"""

from __future__ import annotations

import difflib
import json
import math
import re
import tomllib
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn
from urllib.parse import unquote

import numpy as np
import trimesh

from game.data import ASSET_DIR
from game.errors import SceneError
from game.scene.shapes import (
    box_mesh,
    capsule_mesh,
    cone_mesh,
    cylinder_mesh,
    sphere_mesh,
    transform_mesh,
)
from game.transforms import euler_xyz

# Tessellation of the analytic shapes: enough for smooth silhouettes in shadow maps, few enough
# that a scene of dozens of them stays far below the triangle budget of the static clumps.

DEFAULT_FOV_DEG = 60.0
DEFAULT_NEAR = 0.1  # metres
DEFAULT_FAR = 200.0  # metres
DEFAULT_SPEED = 1.0  # metres per second

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf")
LIGHT_KINDS = ("directional", "spot", "point")

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
TOP_LEVEL_KEYS = ("name", "camera", "light", "linear_light", "floor", "static", "character",
                  "generate")
CAMERA_KEYS = ("position", "target", "fov", "near", "far")
LIGHT_KEYS: dict[str, tuple[str, ...]] = {
    "directional": ("direction",),
    "spot": ("direction", "position", "cone"),
    "point": ("position",),
}
LINEAR_LIGHT_KEYS = ("a", "b")
BODY_KEYS = ("shape", "position", "rotation", "scale")
CHARACTER_KEYS = ("shape", "path", "speed", "phase", "rotation", "scale")

# Hints for keys that are common mistakes, where a close-match suggestion would mislead.
KEY_HINTS = {
    ("character", "position"): "characters have no position; give path = [[x, y, z], ...]",
}


# --------------------------------------------------------------------------------------------
# The model


@dataclass(frozen=True)
class Camera:
    """The start view: a look-at camera with a vertical field of view in degrees."""

    position: np.ndarray
    target: np.ndarray
    fov: float = DEFAULT_FOV_DEG
    near: float = DEFAULT_NEAR
    far: float = DEFAULT_FAR


@dataclass(frozen=True)
class Light:
    """The hard-shadow light.

    ``direction`` is the unit vector the light travels along (directional and spot), ``position``
    its origin (spot and point), ``cone`` the full cone angle in degrees (spot). Fields a kind
    does not use are None.
    """

    kind: str
    direction: np.ndarray | None
    position: np.ndarray | None
    cone: float | None


@dataclass(frozen=True)
class LinearLight:
    """The soft-shadow light: the segment from ``a`` to ``b``."""

    a: np.ndarray
    b: np.ndarray


@dataclass
class Body:
    """A floor or a static object, its mesh already in world space."""

    name: str
    kind: str
    mesh: trimesh.Trimesh


@dataclass
class Character:
    """A rigid shape walking a closed loop.

    ``mesh`` is in local space: analytic shapes are centred on the origin, mesh files keep their
    own coordinates; the optional rotation and scale keys are already applied. The walk adds a yaw
    about +Y that turns local +Z to the direction of travel, then the translation to the path.
    """

    name: str
    mesh: trimesh.Trimesh
    path: np.ndarray
    speed: float
    phase: float

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        """Position (3,) and yaw in radians about +Y at scene time ``t`` seconds.

        The position is the point at arc length ``speed * (t + phase)`` along the closed path
        (last point back to the first), modulo the loop length. The yaw is ``atan2(dx, dz)`` of
        the segment being walked, so local +Z faces the direction of travel. A one-point path
        stands still with yaw 0.
        """
        points = np.asarray(self.path, dtype=np.float64)
        if len(points) == 1:
            return points[0].copy(), 0.0
        deltas = np.roll(points, -1, axis=0) - points
        lengths = np.linalg.norm(deltas, axis=1)
        loop = float(lengths.sum())
        if loop <= 0.0:
            return points[0].copy(), 0.0
        s = (self.speed * (t + self.phase)) % loop
        if s >= loop:  # float modulo of a tiny negative number can return the divisor itself
            s = 0.0
        starts = np.concatenate(([0.0], np.cumsum(lengths)[:-1]))
        # The last segment starting at or before s; zero-length segments share their start with
        # the next one, so side="right" skips them and the yaw never comes from a zero vector.
        i = int(np.searchsorted(starts, s, side="right")) - 1
        f = (s - starts[i]) / lengths[i]
        position = points[i] + f * deltas[i]
        yaw = math.atan2(float(deltas[i, 0]), float(deltas[i, 2]))
        return position, yaw

    def model_matrix(self, t: float) -> np.ndarray:
        """The (4, 4) local-to-world matrix at time ``t``: ``T(position) @ Ry(yaw)``."""
        position, yaw = self.pose(t)
        c, s = math.cos(yaw), math.sin(yaw)
        m = np.eye(4)
        m[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
        m[:3, 3] = position
        return m


@dataclass
class Scene:
    """A loaded scene: the view, the lights and every object, in file order within each kind."""

    name: str
    source: Path | None
    camera: Camera
    light: Light
    linear_light: LinearLight | None
    floors: list[Body]
    statics: list[Body]
    characters: list[Character]

    def object_names(self) -> list[str]:
        """Floors, then statics, then characters: the global object index used everywhere."""
        return ([b.name for b in self.floors] + [b.name for b in self.statics]
                + [c.name for c in self.characters])


# --------------------------------------------------------------------------------------------
# Locating lines in the raw TOML text

_HEADER = re.compile(r"""^\s*(\[\[?)\s*([A-Za-z_"'][^\[\]]*?)\s*\]\]?\s*(#.*)?$""")


def _header_name(raw: str) -> str:
    """The dotted name of a table header with quotes and spaces removed."""
    return ".".join(part.strip().strip("\"'") for part in raw.split("."))


class _Locator:
    """Finds the line of a table, an array-of-tables entry or a key in the raw TOML text.

    Good enough for error messages: it finds the header of the table (counting ``[[static]]``
    headers for the index) and then the first ``key =`` line before the next header.
    """

    def __init__(self, text: str) -> None:
        self.lines = text.splitlines()
        self.headers: list[tuple[int, str]] = []  # (0-based line, table name)
        for i, line in enumerate(self.lines):
            match = _HEADER.match(line)
            if match:
                self.headers.append((i, _header_name(match.group(2))))

    def _table_range(self, table: str | None, index: int | None) -> tuple[int, int] | None:
        if table is None:
            end = self.headers[0][0] if self.headers else len(self.lines)
            return 0, end
        seen = -1
        for h, (line, name) in enumerate(self.headers):
            if name != table:
                continue
            seen += 1
            if index is None or seen == index:
                end = self.headers[h + 1][0] if h + 1 < len(self.headers) else len(self.lines)
                return line, end
        return None

    def line(self, table: str | None, index: int | None = None, key: str | None = None) -> int:
        """The 1-based line of ``table[index].key`` (or of the table, or 1 if not found)."""
        span = self._table_range(table, index)
        if span is None:
            # Perhaps an inline table at the top level: `camera = { ... }`.
            if table is not None and "." not in table:
                return self.line(None, None, table)
            return 1
        start, end = span
        if key is not None:
            pattern = re.compile(rf"""^\s*(["']?){re.escape(key)}\1\s*=""")
            for i in range(start, end):
                if pattern.match(self.lines[i]):
                    return i + 1
        return start + 1 if table is not None else 1


# --------------------------------------------------------------------------------------------
# Validation


class _Context:
    """What every check needs to report: the file's label and the line locator."""

    def __init__(self, text: str, source: Path | None, base_dir: Path) -> None:
        self.label = str(source) if source is not None else "<scene>"
        self.locator = _Locator(text)
        self.base_dir = base_dir

    def fail(self, table: str | None, index: int | None, key: str | None,
             problem: str) -> NoReturn:
        """Raise the one-line SceneError for ``table[index].key``."""
        line = self.locator.line(table, index, key)
        where = table or ""
        if index is not None:
            where += f"[{index}]"
        if key is not None:
            where = f"{where}.{key}" if where else key
        raise SceneError(f"{self.label}:{line}: {where}: {problem}")


def _describe(value: Any) -> str:
    """A short repr of a TOML value for messages."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _suggest(word: str, choices: Iterable[str]) -> str:
    """`, did you mean 'x'?` for a near match, or the list of valid choices."""
    choices = list(choices)
    close = difflib.get_close_matches(word, choices, n=1)
    if close:
        return f", did you mean '{close[0]}'?"
    return f" (expected one of: {', '.join(choices)})" if choices else ""


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


class _Table:
    """One TOML table being read: typed getters that fail with the table's location."""

    def __init__(self, ctx: _Context, name: str, index: int | None, data: Any) -> None:
        self.ctx, self.name, self.index = ctx, name, index
        if not isinstance(data, dict):
            ctx.fail(name, index, None, f"must be a table, got {_describe(data)}")
        self.data: dict[str, Any] = data

    def fail(self, key: str | None, problem: str) -> NoReturn:
        self.ctx.fail(self.name, self.index, key, problem)

    def check_keys(self, allowed: Iterable[str], other: Mapping[str, str] | None = None) -> None:
        """Reject keys outside ``allowed``; ``other`` maps known-but-misplaced keys to a reason."""
        allowed = list(allowed)
        for key in self.data:
            if key in allowed:
                continue
            if other and key in other:
                self.fail(key, other[key])
            hint = KEY_HINTS.get((self.name, key))
            if hint:
                self.fail(key, f"unknown key: {hint}")
            self.fail(key, "unknown key" + _suggest(key, allowed))

    def has(self, key: str) -> bool:
        return key in self.data

    def require(self, key: str) -> Any:
        if key not in self.data:
            self.fail(key, "missing required key")
        return self.data[key]

    def number(self, key: str, default: float | None = None, *, positive: bool = False,
               non_negative: bool = False, below: float | None = None) -> float:
        """A finite number; ``default`` None makes the key required."""
        value = self.data.get(key, default) if default is not None else self.require(key)
        return self._check_number(key, value, positive=positive, non_negative=non_negative,
                                  below=below)

    def _check_number(self, key: str, value: Any, *, positive: bool = False,
                      non_negative: bool = False, below: float | None = None) -> float:
        if not _is_number(value):
            self.fail(key, f"must be a number, got {_describe(value)}")
        value = float(value)
        if not math.isfinite(value):
            self.fail(key, f"must be finite, got {value}")
        if positive and value <= 0.0:
            self.fail(key, f"must be positive, got {value}")
        if non_negative and value < 0.0:
            self.fail(key, f"must not be negative, got {value}")
        if below is not None and value >= below:
            self.fail(key, f"must be less than {below:g}, got {value}")
        return value

    def vec3(self, key: str, default: Iterable[float] | None = None, *,
             positive: bool = False) -> np.ndarray:
        """Three finite numbers as a (3,) float64 array; ``default`` None makes it required."""
        value = self.data.get(key, list(default)) if default is not None else self.require(key)
        return self._check_vec3(key, value, positive=positive)

    def _check_vec3(self, key: str, value: Any, *, positive: bool = False) -> np.ndarray:
        if (not isinstance(value, list) or len(value) != 3
                or not all(_is_number(v) for v in value)):
            self.fail(key, f"must be a list of 3 numbers [x, y, z], got {_describe(value)}")
        array = np.array(value, dtype=np.float64)
        if not np.all(np.isfinite(array)):
            self.fail(key, f"must be finite, got {value}")
        if positive and np.any(array <= 0.0):
            self.fail(key, f"must be positive, got {value}")
        return array

    def string(self, key: str, choices: Iterable[str] | None = None,
               default: str | None = None) -> str:
        value = self.data.get(key, default) if default is not None else self.require(key)
        if not isinstance(value, str):
            self.fail(key, f"must be a string, got {_describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"unknown value '{value}'" + _suggest(value, choices))
        return value

    def scale(self, key: str = "scale") -> np.ndarray:
        """A positive number or three positive numbers, as a (3,) array; default 1."""
        value = self.data.get(key, 1.0)
        if _is_number(value):
            return np.full(3, self._check_number(key, value, positive=True))
        if isinstance(value, list):
            return self._check_vec3(key, value, positive=True)
        self.fail(key, f"must be a number or a list of 3 numbers, got {_describe(value)}")


def _shape_mesh(table: _Table, extra_keys: Iterable[str]) -> trimesh.Trimesh:
    """The local mesh of a floor, static or character table, checking its keys."""
    shape = table.string("shape", choices=list(SHAPE_KEYS))
    own = SHAPE_KEYS[shape]
    misplaced = {k: f"not a key of shape '{shape}' ({shape} takes: {', '.join(own)})"
                 for k in ALL_SHAPE_KEYS if k not in own}
    table.check_keys([*extra_keys, *own], misplaced)
    if shape == "box":
        return box_mesh(table.vec3("size", positive=True))
    if shape == "sphere":
        return sphere_mesh(table.number("radius", positive=True))
    if shape == "mesh":
        return _load_mesh_file(table)
    radius = table.number("radius", positive=True)
    height = table.number("height", positive=True)
    if shape == "cylinder":
        return cylinder_mesh(radius, height)
    if shape == "cone":
        return cone_mesh(radius, height)
    if height < 2.0 * radius:
        table.fail("height", f"a capsule's total height must be at least 2 * radius "
                             f"({2.0 * radius:g}), got {height:g}")
    return capsule_mesh(radius, height)


# --------------------------------------------------------------------------------------------
# Mesh files


def _inside(base_dir: Path, relative: str, fail: Callable[[str], NoReturn]) -> Path:
    """``base_dir / relative`` if it stays inside ``base_dir``, checked before anything opens it."""
    if not relative:
        fail("must name a file")
    if (relative.startswith(("/", "\\")) or re.match(r"^[A-Za-z]:", relative)
            or Path(relative).is_absolute()):
        fail(f"absolute paths are not allowed, give a path relative to the scene's folder: "
             f"{relative}")
    depth = 0
    for part in re.split(r"[/\\]", relative):
        if part == "..":
            depth -= 1
            if depth < 0:
                fail(f"path leaves the scene's folder: {relative}")
        elif part not in ("", "."):
            depth += 1
    root = base_dir.resolve()
    full = (base_dir / relative).resolve()
    if not full.is_relative_to(root):
        fail(f"path resolves outside the scene's folder (through a symlink): {relative}")
    return full


def _check_gltf_uris(path: Path, root: Path, fail: Callable[[str], NoReturn]) -> None:
    """A .gltf names its buffers and images by URI: they must stay inside the folder too."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        fail(f"not a glTF file: {path.name} ({_one_line(str(error))})")
    if not isinstance(document, dict):
        fail(f"not a glTF file: {path.name}")
    for section in ("buffers", "images"):
        for entry in document.get(section, []) or []:
            uri = entry.get("uri") if isinstance(entry, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            target = Path(unquote(uri))
            if "://" in uri or target.is_absolute():
                fail(f"glTF {section} URI must be a relative file name: {uri}")
            if not (path.parent / target).resolve().is_relative_to(root):
                fail(f"glTF {section} URI leaves the scene's folder: {uri}")


def _one_line(text: str, limit: int = 120) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _load_mesh_file(table: _Table) -> trimesh.Trimesh:
    """Load ``file`` with trimesh: validated, zero-area triangles dropped, in file coordinates."""
    relative = table.require("file")
    if not isinstance(relative, str):
        table.fail("file", f"must be a string, got {_describe(relative)}")

    def fail(problem: str) -> NoReturn:
        table.fail("file", problem)

    base_dir = table.ctx.base_dir
    path = _inside(base_dir, relative, fail)
    suffix = Path(relative).suffix.lower()
    if suffix not in MESH_SUFFIXES:
        fail(f"unsupported mesh format '{suffix or relative}' "
             f"(expected {', '.join(MESH_SUFFIXES)})")
    if not path.is_file():
        fail(f"file not found: {relative}" if not path.exists() else f"not a file: {relative}")
    try:
        with path.open("rb") as probe:
            empty = not probe.read(1)
    except OSError as error:
        fail(f"cannot open {relative}: {error.strerror or error}")
    if empty:
        fail(f"empty file: {relative}")
    kwargs: dict[str, Any] = {}
    if suffix == ".gltf":
        _check_gltf_uris(path, base_dir.resolve(), fail)
    elif suffix == ".obj":
        # Materials are not used (flat shading), and an mtllib could name a file outside the folder.
        kwargs["skip_materials"] = True
    try:
        loaded = trimesh.load(str(path), file_type=suffix[1:], force="mesh", process=False,
                              **kwargs)
    except Exception as error:  # noqa: BLE001 - trimesh raises anything on a corrupt file
        fail(f"cannot read mesh {relative}: {_one_line(str(error)) or type(error).__name__}")
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        fail(f"no triangles in {relative} (not a mesh file?)")
    vertices = np.asarray(loaded.vertices, dtype=np.float64)
    faces = np.asarray(loaded.faces, dtype=np.int64)
    if faces.min() < 0 or faces.max() >= len(vertices):
        fail(f"face indices out of range in {relative}")
    if not np.all(np.isfinite(vertices)):
        fail(f"non-finite vertex coordinates in {relative}")
    corners = vertices[faces]
    areas = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    extent = float(np.ptp(vertices[faces.ravel()], axis=0).max())
    keep = areas > 1e-12 * max(extent, 1e-300) ** 2
    if not keep.all():
        if not keep.any():
            fail(f"every triangle in {relative} has zero area")
        warnings.warn(f"{table.ctx.label}: {relative}: removed {int((~keep).sum())} "
                      f"zero-area triangles", stacklevel=2)
        faces = faces[keep]
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


# --------------------------------------------------------------------------------------------
# Tables


def _parse_camera(ctx: _Context, data: Any) -> Camera:
    table = _Table(ctx, "camera", None, data)
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
    return Camera(position=position, target=target, fov=fov, near=near, far=far)


def _parse_light(ctx: _Context, data: Any) -> Light:
    if isinstance(data, list):
        ctx.fail("light", 1 if len(data) > 1 else None, None,
                 f"exactly one [light] table is allowed, got an array of {len(data)}")
    table = _Table(ctx, "light", None, data)
    kind = table.string("kind", LIGHT_KINDS)
    needed = LIGHT_KEYS[kind]
    misplaced = {k: f"not used by a '{kind}' light ({kind} takes: {', '.join(needed)})"
                 for k in ("direction", "position", "cone") if k not in needed}
    table.check_keys(("kind", *needed), misplaced)
    direction = position = cone = None
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
    return Light(kind=kind, direction=direction, position=position, cone=cone)


def _parse_linear_light(ctx: _Context, data: Any) -> LinearLight:
    table = _Table(ctx, "linear_light", None, data)
    table.check_keys(LINEAR_LIGHT_KEYS)
    a, b = table.vec3("a"), table.vec3("b")
    if np.allclose(a, b):
        table.fail("b", "the segment has zero length (a == b)")
    return LinearLight(a=a, b=b)


def _entries(ctx: _Context, data: dict[str, Any], kind: str) -> list[Any]:
    """The entries of an array of tables ``[[kind]]``."""
    value = data.get(kind, [])
    if not isinstance(value, list):
        ctx.fail(kind, None, None, f"must be an array of tables, write [[{kind}]]")
    return value


def _parse_body(ctx: _Context, kind: str, index: int, data: Any) -> Body:
    table = _Table(ctx, kind, index, data)
    local = _shape_mesh(table, BODY_KEYS)
    position = table.vec3("position", (0.0, 0.0, 0.0))
    rotation = table.vec3("rotation", (0.0, 0.0, 0.0))
    scale = table.scale()
    linear = euler_xyz(rotation) @ np.diag(scale)
    return Body(name=f"{kind}_{index}", kind=kind, mesh=transform_mesh(local, linear, position))


def _parse_path(table: _Table) -> np.ndarray:
    value = table.require("path")
    if not isinstance(value, list) or not value:
        table.fail("path", f"must be a non-empty list of [x, y, z] points, got "
                           f"{_describe(value)}")
    points = np.array([_point(table, i, p) for i, p in enumerate(value)])
    if len(points) > 1:
        loop = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum()
        if loop <= 0.0:
            table.fail("path", "the loop has zero length (every point is the same)")
    return points


def _point(table: _Table, i: int, value: Any) -> np.ndarray:
    if (not isinstance(value, list) or len(value) != 3
            or not all(_is_number(v) for v in value)):
        table.fail("path", f"point {i} must be a list of 3 numbers [x, y, z], got "
                           f"{_describe(value)}")
    point = np.array(value, dtype=np.float64)
    if not np.all(np.isfinite(point)):
        table.fail("path", f"point {i} must be finite, got {value}")
    return point


def _parse_character(ctx: _Context, index: int, data: Any) -> Character:
    table = _Table(ctx, "character", index, data)
    local = _shape_mesh(table, CHARACTER_KEYS)
    path = _parse_path(table)
    speed = table.number("speed", DEFAULT_SPEED, non_negative=True)
    phase = table.number("phase", 0.0)
    rotation = table.vec3("rotation", (0.0, 0.0, 0.0))
    scale = table.scale()
    mesh = transform_mesh(local, euler_xyz(rotation) @ np.diag(scale))
    return Character(name=f"character_{index}", mesh=mesh, path=path, speed=speed, phase=phase)


def _add_generated(ctx: _Context, data: Any, floors: list[Body], statics: list[Body],
                   characters: list[Character]) -> None:
    """Append the procedural town of a ``[generate]`` table, continuing the numbering."""
    # Imported here: the generator builds its shapes with this module's helpers.
    from game.scene import generate

    table = _Table(ctx, "generate", None, data)
    params = generate.town_params(table.data, table.fail)
    town = generate.generate_town(params)
    for mesh in town.floors:
        floors.append(Body(name=f"floor_{len(floors)}", kind="floor", mesh=mesh))
    for mesh in town.statics:
        statics.append(Body(name=f"static_{len(statics)}", kind="static", mesh=mesh))
    for walker in town.walkers:
        characters.append(Character(name=f"character_{len(characters)}", mesh=walker.mesh,
                                    path=walker.path, speed=walker.speed, phase=walker.phase))


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
    ctx = _Context(text, source, Path(base_dir))
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        message = str(error)
        match = re.search(r"at line (\d+)", message)
        line = int(match.group(1)) if match else max(len(text.splitlines()), 1)
        raise SceneError(f"{ctx.label}:{line}: TOML syntax error: {message}") from None

    for key in data:
        if key not in TOP_LEVEL_KEYS:
            line = ctx.locator.line(key)  # its [header], else its `key =` line
            raise SceneError(f"{ctx.label}:{line}: {key}: unknown key"
                             + _suggest(key, TOP_LEVEL_KEYS))
    name = data.get("name", source.stem if source is not None else "scene")
    if not isinstance(name, str):
        ctx.fail(None, None, "name", f"must be a string, got {_describe(name)}")
    for required in ("camera", "light"):
        if required not in data:
            raise SceneError(f"{ctx.label}:1: {required}: missing required table [{required}]")

    camera = _parse_camera(ctx, data["camera"])
    light = _parse_light(ctx, data["light"])
    linear_light = (_parse_linear_light(ctx, data["linear_light"])
                    if "linear_light" in data else None)
    floors = [_parse_body(ctx, "floor", i, d) for i, d in enumerate(_entries(ctx, data, "floor"))]
    statics = [_parse_body(ctx, "static", i, d)
               for i, d in enumerate(_entries(ctx, data, "static"))]
    characters = [_parse_character(ctx, i, d)
                  for i, d in enumerate(_entries(ctx, data, "character"))]
    if "generate" in data:
        _add_generated(ctx, data["generate"], floors, statics, characters)
    return Scene(name=name, source=source, camera=camera, light=light, linear_light=linear_light,
                 floors=floors, statics=statics, characters=characters)


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; raises SceneError with a one-line message."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise SceneError(f"{path}: cannot read scene file: {error.strerror or error}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw[: error.start].count(b"\n") + 1
        raise SceneError(f"{path}:{line}: not a UTF-8 text file") from None
    return parse_scene(text, source=path, base_dir=path.parent)


def default_scene_path() -> Path:
    """The built-in default scene, assets/default.toml."""
    return ASSET_DIR / "default.toml"
