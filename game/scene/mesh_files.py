"""Mesh files of the scene format (obj, stl, ply, glb, gltf), loaded with trimesh.

A path is checked before anything opens it: it must stay inside the scene's folder, and so must
every file a glTF names by URI.
"""

from __future__ import annotations

import json
import re
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn
from urllib.parse import unquote

import numpy as np
import trimesh

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf")


def inside(base_dir: Path, relative: str, fail: Callable[[str], NoReturn]) -> Path:
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


def load_mesh_file(relative: str, base_dir: Path, label: str,
                   fail: Callable[[str], NoReturn]) -> trimesh.Trimesh:
    """Load ``relative`` (inside ``base_dir``) with trimesh: validated, zero-area triangles
    dropped, in file coordinates. ``fail`` raises the scene's one-line error; ``label`` names the
    scene file in warnings."""
    path = inside(base_dir, relative, fail)
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
        warnings.warn(f"{label}: {relative}: removed {int((~keep).sum())} "
                      f"zero-area triangles", stacklevel=2)
        faces = faces[keep]
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
