"""Mesh files of the scene format (obj, stl, ply, glb, gltf), loaded with trimesh.

A path is checked before anything opens it: it must stay inside the scene's folder, and so must
every file a glTF or GLB names by URI (game/gltf.py, whatever trimesh itself would do).
"""

from __future__ import annotations

import io
import os
import re
import stat
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO, NoReturn

import numpy as np
import trimesh

from game import gltf
from game.scene.parts import MAX_PARTS, obj_part_count

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf")
MAX_MESH_FILE_BYTES = 512 * 2**20  # one mesh file (with a glTF's buffer files)
MAX_FILE_COORDINATE = 1e9  # a vertex coordinate in the file's own units, before its scale
# What one mesh file may draw, counting every placement of a glTF mesh by its nodes: as much as
# the largest generated town (game/scene/generate.py), checked before anything is allocated.
MAX_INSTANCED_TRIANGLES = 16_000_000
FILE_PART = "file_part"
"""The face attribute that holds each face's part of the file's own structure (an index)."""
FILE_COLOUR = "file_colour"
"""The face attribute that holds each face's base colour from the file's material, linear RGB
(glTF's baseColorFactor; :data:`NO_COLOUR` where the part has none)."""
NO_COLOUR = -1.0   # a colour component that says "no colour given" (the shader's palette)
FILE_NORMAL = "file_normal"
"""The vertex attribute that holds each vertex's normal as the file gives it (glTF NORMAL, OBJ
``vn``), in the mesh's coordinates; NaN where the file gives none."""


def inside(base_dir: Path, relative: str, fail: Callable[[str], NoReturn]) -> Path:
    """``base_dir / relative`` if it stays inside ``base_dir``, checked before anything opens it."""
    if not relative:
        fail("must name a file")
    if "\0" in relative:
        fail("a path cannot hold a NUL character")
    if any(len(part.encode()) > 255 for part in re.split(r"[/\\]", relative)):
        fail("a name in the path is longer than 255 bytes")
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
    try:
        root = base_dir.resolve()
        full = (base_dir / relative).resolve()
    except (OSError, RuntimeError) as error:  # RuntimeError: a symlink loop
        fail(f"cannot follow the path {relative}: {error}")
    if not full.is_relative_to(root):
        fail(f"path resolves outside the scene's folder (through a symlink): {relative}")
    return full


def regular_file(path: Path, shown: str, fail: Callable[[str], NoReturn]) -> Path:
    """``path`` if it is a regular file; every file a scene, a glTF or a bench folder names
    passes here, or through :func:`open_regular`, before it is read. A FIFO would block the read
    for good, and a device or a folder never gives what the reader expects."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        fail(f"file not found: {shown}" + (f" (looked for at {path})" if str(path) != shown
                                           else ""))
    except (OSError, ValueError) as error:  # ValueError: a NUL byte in the path
        fail(f"cannot open {shown}: {getattr(error, 'strerror', None) or error}")
    _refuse_special(mode, shown, fail)
    return path


def open_regular(path: Path, shown: str, fail: Callable[[str], NoReturn]) -> BinaryIO:
    """``path`` opened for reading, once :func:`regular_file` passes it and its open handle is
    a regular file too: opened without waiting (opening a FIFO waits for a writer), so a file
    swapped for a FIFO after the check still cannot block the read."""
    regular_file(path, shown, fail)
    try:
        handle = open(path, "rb", opener=_without_waiting)  # noqa: SIM115 - the caller closes it
    except OSError as error:
        fail(f"cannot open {shown}: {error.strerror or error}")
    try:
        _refuse_special(os.fstat(handle.fileno()).st_mode, shown, fail)
    except BaseException:
        handle.close()
        raise
    return handle


def _without_waiting(path: str, flags: int) -> int:
    return os.open(path, flags | os.O_NONBLOCK)


def _refuse_special(mode: int, shown: str, fail: Callable[[str], NoReturn]) -> None:
    if not stat.S_ISREG(mode):
        kind = ("a folder" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode)
                else "a device or socket")
        fail(f"{shown}: not a regular file ({kind})")


class CheckedFiles(trimesh.resolvers.Resolver):
    """What trimesh may read for a glTF: the buffer files already checked, by their URI as
    the file writes it, and nothing else (trimesh's own resolver would stop at the glTF's
    folder, which is narrower than the scene's, and open whatever it is given)."""

    def __init__(self, files: dict[str, Path]):
        self.files = files

    def get(self, key: str) -> bytes:
        # Checked again as it is opened, in case the file was swapped since.
        with open_regular(self.files[key], key, _raise_os_error) as buffer:
            return buffer.read()

    def keys(self):
        return self.files.keys()

    def write(self, name: str, data) -> None:
        raise OSError("mesh files are only read")

    def namespaced(self, namespace: str) -> CheckedFiles:
        return self


def _raise_os_error(problem: str) -> NoReturn:
    raise OSError(problem)


class _Unknown(Exception):
    """A file whose count :func:`known_draw` leaves to the loader, which says what is wrong."""


def _unknown(problem: str) -> NoReturn:
    raise _Unknown(problem)


def known_draw(relative: str, base_dir: Path) -> tuple[Path, tuple[int, int]] | None:
    """The path of mesh file ``relative`` and the triangles and vertices it draws, where its
    header says so before any mesh is read: a glTF's node tree (every placement of a mesh), a
    binary STL's triangle count. None for other formats, and for a file that
    :func:`load_mesh_file` refuses: it says why, in the scene's order."""
    try:
        path, suffix = _checked_path(relative, base_dir, _unknown)
        if suffix not in (".glb", ".gltf", ".stl"):
            return None
        with open_regular(path, relative, _unknown) as handle:
            size = os.fstat(handle.fileno()).st_size
            if size > MAX_MESH_FILE_BYTES:
                return None
            if suffix != ".stl":
                return path, gltf.drawn(handle, suffix == ".glb", MAX_INSTANCED_TRIANGLES)
            count = int.from_bytes(handle.read(84)[80:84], "little")
            # trimesh keeps a binary STL's three corners per triangle, unshared
            return (path, (count, 3 * count)) if size == 84 + 50 * count else None
    except (_Unknown, gltf.GltfError, OSError):
        return None


def binary_stl_damage(head: bytes, size: int) -> str | None:
    """What is wrong with an STL file that is neither text nor a whole binary STL, or None.

    A binary STL's header gives its triangle count and so its exact size. trimesh reads a file of
    any other size as text, and what it then reports (no triangles, an encoding error, a missing
    optional module) depends on the modules installed, so the damage is named here from the
    first 84 bytes (``head``) and the size."""
    if size >= 84:
        count = int.from_bytes(head[80:84], "little")
        if size == 84 + 50 * count:
            return None
    if head.lstrip()[:5].lower() == b"solid":  # a text STL
        return None
    if size < 84:
        return f"damaged or truncated binary STL file ({size} bytes, shorter than its header)"
    return (f"damaged or truncated binary STL file (its header says {count} triangles, "
            f"{84 + 50 * count} bytes; the file has {size})")


def _one_line(text: str, limit: int = 120) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def load_mesh_file(relative: str, base_dir: Path, label: str,
                   fail: Callable[[str], NoReturn]) -> trimesh.Trimesh:
    """Load ``relative`` (inside ``base_dir``) with trimesh: validated, zero-area triangles
    dropped, in file coordinates, each face's structural part in
    ``face_attributes[FILE_PART]``. ``fail`` raises the scene's one-line error; ``label`` names
    the scene file in warnings."""
    path, suffix = _checked_path(relative, base_dir, fail)
    # One handle, checked as it was opened, serves every read: nothing opens the path again.
    with open_regular(path, relative, fail) as handle:
        size = _checked_size(handle, relative, fail)
        source, kwargs = _trimesh_source(handle, path, relative, suffix, size, base_dir, fail)
        pieces, piece_normals = _read_pieces(source, relative, suffix, kwargs, fail)
    vertices, faces, parts, colours = _joined(pieces, relative, fail)
    keep = _nonzero_area(vertices, faces)
    if not keep.all():
        if not keep.any():
            fail(f"every triangle in {relative} has zero area")
        warnings.warn(f"{label}: {relative}: removed {int((~keep).sum())} "
                      f"zero-area triangles", stacklevel=2)
        faces, parts, colours = faces[keep], parts[keep], colours[keep]
    attributes = {FILE_PART: parts}
    if np.any(colours >= 0.0):
        attributes[FILE_COLOUR] = colours
    normals = np.concatenate(piece_normals)
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False,
                           face_attributes=attributes,
                           vertex_attributes=({FILE_NORMAL: normals}
                                              if np.isfinite(normals).any() else {}))


def _checked_path(relative: str, base_dir: Path,
                  fail: Callable[[str], NoReturn]) -> tuple[Path, str]:
    """The mesh file's path inside ``base_dir`` and its suffix (lower case), once the suffix is
    a supported format."""
    path = inside(base_dir, relative, fail)
    suffix = Path(relative).suffix.lower()
    if suffix not in MESH_SUFFIXES:
        fail(f"unsupported mesh format '{suffix or relative}' "
             f"(expected {', '.join(MESH_SUFFIXES)})")
    return path, suffix


def _checked_size(handle: BinaryIO, relative: str, fail: Callable[[str], NoReturn]) -> int:
    """The open file's size, once it is known to be non-empty and at most
    MAX_MESH_FILE_BYTES; the handle is left at its start."""
    try:
        empty = not handle.read(1)
        handle.seek(0)
    except OSError as error:
        fail(f"cannot open {relative}: {error.strerror or error}")
    if empty:
        fail(f"empty file: {relative}")
    size = os.fstat(handle.fileno()).st_size
    if size > MAX_MESH_FILE_BYTES:
        fail(f"{relative} is {size / 2**20:.0f} MiB, more than the {MAX_MESH_FILE_BYTES // 2**20} "
             "MiB a mesh file may hold")
    return size


def _trimesh_source(handle: BinaryIO, path: Path, relative: str, suffix: str, size: int,
                    base_dir: Path, fail: Callable[[str], NoReturn]
                    ) -> tuple[Any, dict[str, Any]]:
    """What to hand ``trimesh.load`` for the open file (the handle itself, or the checked bytes
    of a glTF or GLB) and the keyword arguments its format needs; a damaged binary STL, or an
    OBJ of more groups than a mesh may have parts, fails here."""
    kwargs: dict[str, Any] = {}
    if suffix in (".glb", ".gltf"):
        return _gltf_source(handle.read(), path, relative, suffix, base_dir, fail)
    if suffix == ".stl":
        damage = binary_stl_damage(handle.read(84), size)
        if damage:
            fail(f"cannot read mesh {relative}: {damage}")
    elif suffix == ".obj":
        # trimesh splits the file by these before any limit could apply, in time and memory
        # that grow with their number: counted first, in one streaming pass.
        parts = obj_part_count(handle, MAX_PARTS)
        if parts > MAX_PARTS:
            fail(f"{relative} has more than {MAX_PARTS:,} objects and groups with faces (o, g "
                 f"and usemtl); a mesh file may have at most {MAX_PARTS:,} parts")
        # Materials are not used (flat shading), and an mtllib could name a file outside the folder.
        kwargs["skip_materials"] = True
        kwargs.update(split_objects=True, split_groups=True)  # its parts (game/scene/parts.py)
    handle.seek(0)
    return handle, kwargs


def _gltf_source(data: bytes, path: Path, relative: str, suffix: str, base_dir: Path,
                 fail: Callable[[str], NoReturn]) -> tuple[Any, dict[str, Any]]:
    """A glTF or GLB read here, URIs, node tree and sizes checked and images left out, before
    trimesh sees any of it; trimesh reads its buffer files through :class:`CheckedFiles`."""
    try:
        checked = gltf.checked(data, suffix == ".glb", path.parent, base_dir,
                               MAX_INSTANCED_TRIANGLES)
    except gltf.GltfError as error:
        fail(f"cannot read mesh {relative}: {error}")
    files, total = {}, 0
    for uri, full, declared in checked.files:
        shown = full.relative_to(base_dir.resolve()).as_posix()
        size = os.stat(regular_file(full, shown, fail)).st_size
        if size < declared:
            fail(f"cannot read mesh {relative}: its buffer file {shown} holds {size:,} bytes; "
                 f"the buffer declares {declared:,}")
        total += size
        files[uri] = full
    if total > MAX_MESH_FILE_BYTES:
        fail(f"the buffers of {relative} hold more than {MAX_MESH_FILE_BYTES // 2**20} MiB")
    return io.BytesIO(checked.data), {"resolver": CheckedFiles(files)}


def _read_pieces(source: Any, relative: str, suffix: str, kwargs: dict[str, Any],
                 fail: Callable[[str], NoReturn]
                 ) -> tuple[list[trimesh.Trimesh], list[np.ndarray]]:
    """The file's meshes placed by its scene graph, with their normals (:func:`_placed_pieces`);
    whatever trimesh raises on a corrupt file becomes the scene's error."""
    try:
        # As a scene, to keep the file's structure (OBJ objects and material groups, glTF
        # nodes and primitives: game/scene/parts.py), then concatenated here as force="mesh"
        # would, with each face's part recorded.
        loaded = trimesh.load(source, file_type=suffix[1:], force="scene", process=False,
                              **kwargs)
        return _placed_pieces(loaded)
    except ImportError:
        # trimesh reaches for optional modules (charset_normalizer, to guess the text encoding
        # of a binary STL whose size does not match its triangle count) when a file is damaged.
        fail(f"cannot read mesh {relative}: damaged or truncated {suffix[1:].upper()} file")
    except Exception as error:  # noqa: BLE001 - trimesh raises anything on a corrupt file
        fail(f"cannot read mesh {relative}: {_one_line(str(error)) or type(error).__name__}")


def _joined(pieces: list[trimesh.Trimesh], relative: str, fail: Callable[[str], NoReturn]
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pieces as one mesh: vertices, faces, each face's piece and base colour; fails on a
    file without triangles, with face indices out of range or with unusable coordinates."""
    if not pieces:
        fail(f"no triangles in {relative} (not a mesh file?)")
    for piece in pieces:
        f, v = np.asarray(piece.faces), np.asarray(piece.vertices)
        if f.min() < 0 or f.max() >= len(v):
            fail(f"face indices out of range in {relative}")
        if v.ndim != 2 or v.shape[1] != 3:
            fail(f"vertices without three coordinates (x, y, z) in {relative}")
    offsets = np.cumsum([0] + [len(p.vertices) for p in pieces])
    vertices = np.concatenate([np.asarray(p.vertices, dtype=np.float64) for p in pieces])
    faces = np.concatenate([np.asarray(p.faces, dtype=np.int64) + offset
                            for p, offset in zip(pieces, offsets, strict=False)])
    parts = np.repeat(np.arange(len(pieces)), [len(p.faces) for p in pieces])
    colours = np.repeat(np.array([_piece_colour(p) for p in pieces]).reshape(-1, 3),
                        [len(p.faces) for p in pieces], axis=0)
    if not np.all(np.isfinite(vertices)):
        fail(f"non-finite vertex coordinates in {relative}")
    reach = float(np.abs(vertices).max())
    if reach > MAX_FILE_COORDINATE:
        # float32 (what the GPU and the dumps hold) would turn these into inf, and a mesh that
        # mixes them with unit coordinates loses every small triangle.
        fail(f"vertex coordinates up to {reach:.3g} in {relative}; at most "
             f"{MAX_FILE_COORDINATE:g}")
    return vertices, faces, parts, colours


def _nonzero_area(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Which faces have an area, measured against the triangle's own size, not the mesh's: a
    small triangle far from a large one is still a triangle."""
    corners = vertices[faces]
    areas = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    longest = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    return areas > 1e-12 * longest ** 2


def _placed_pieces(loaded: trimesh.Scene) -> tuple[list[trimesh.Trimesh], list[np.ndarray]]:
    """Every mesh of the file's scene graph moved to where its node places it (as trimesh's
    ``Scene.dump`` does), with the normals the file gives its vertices, turned the same way.

    ``dump`` would recompute the normals from the faces: the file's own are read from the
    geometry before it is moved (trimesh keeps them in its cache, where the loader put them).
    """
    pieces, normals = [], []
    for node in loaded.graph.nodes_geometry:
        transform, name = loaded.graph[node]
        geometry = loaded.geometry[name]
        if not isinstance(geometry, trimesh.Trimesh) or not len(geometry.faces):
            continue
        piece = geometry.copy()
        piece.apply_transform(transform)
        pieces.append(piece)
        given = np.full((len(geometry.vertices), 3), np.nan)
        if "vertex_normals" in geometry._cache:  # the loader's, not computed from the faces
            file_normals = np.asarray(geometry.vertex_normals, np.float64)
            if file_normals.shape == given.shape:
                given = turn_normals(file_normals, np.asarray(transform)[:3, :3])
        normals.append(given)
    return pieces, normals


def turn_normals(normals: np.ndarray, linear: np.ndarray) -> np.ndarray:
    """Normals under the linear map ``linear`` (its inverse transpose), unit length; NaN where a
    normal is zero, not finite or the map is singular."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        try:
            turned = normals @ np.linalg.inv(np.asarray(linear, np.float64))
        except np.linalg.LinAlgError:
            return np.full(normals.shape, np.nan)
        length = np.linalg.norm(turned, axis=1)
        unit = turned / length[:, None]
    unit[~(np.isfinite(unit).all(axis=1) & (length > 0.0))] = np.nan
    return unit


def _piece_colour(piece: trimesh.Trimesh) -> tuple[float, float, float]:
    """The base colour of a loaded piece's material (linear RGB), if the file gave one: only
    glTF materials reach here, cut down to their colour factor (game/gltf.py)."""
    material = getattr(piece.visual, "material", None)
    factor = getattr(material, "baseColorFactor", None)
    if factor is None:
        return (NO_COLOUR,) * 3
    rgb = np.asarray(factor, dtype=np.float64).reshape(-1)[:3]
    if np.asarray(factor).dtype == np.uint8:   # trimesh keeps the factor as bytes
        rgb = rgb / 255.0
    return tuple(float(v) for v in np.clip(rgb, 0.0, 1.0))
