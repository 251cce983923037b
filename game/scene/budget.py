"""What a whole scene draws after instancing, held to one total before the meshes are built.

Each mesh file, glTF and ``[generate]`` town has a limit of its own, but a scene of many entries
that each pass could still add up to more than memory holds: a large file named by many
``[[static]]`` entries, a glTF whose nodes place one mesh many times, a crowd of walkers each
with its own mesh. Counted here: every floor, static and character (a mesh file as often as
entries name it, a glTF's mesh as often as its nodes place it) and a generated town's floors,
statics and walkers.

Where a count is known before anything is built (an analytic shape, a glTF's node tree, a binary
STL's header), the whole scene is counted first and refused at once. The rest (OBJ, PLY, text
STL) is counted as it is loaded, and a file an earlier entry has loaded is counted again before
it is read, so the total is never passed by more than one file.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import cache, partial
from pathlib import Path
from typing import Any, NoReturn

import trimesh

from game.scene.mesh_files import inside, known_draw, load_mesh_file
from game.scene.shapes import box_mesh, capsule_mesh, cone_mesh, cylinder_mesh, sphere_mesh

# As much as one mesh file may draw (game/scene/mesh_files.py) and as much as the largest
# generated town (game/scene/generate.py): either fits a scene alone.
MAX_SCENE_TRIANGLES = 16_000_000
MAX_SCENE_VERTICES = 16_000_000
ENTRY_KINDS = ("floor", "static", "character")

# Each analytic shape at a nominal size: its triangles and vertices do not depend on its size.
_NOMINAL: dict[str, Callable[[], trimesh.Trimesh]] = {
    "box": lambda: box_mesh((1.0, 1.0, 1.0)),
    "sphere": lambda: sphere_mesh(1.0),
    "cylinder": lambda: cylinder_mesh(1.0, 1.0),
    "capsule": lambda: capsule_mesh(0.5, 2.0),
    "cone": lambda: cone_mesh(1.0, 1.0),
}

Fail = Callable[[str], NoReturn]


@cache
def shape_draw(shape: str) -> tuple[int, int]:
    """The triangles and vertices of an analytic shape."""
    mesh = _NOMINAL[shape]()
    return len(mesh.faces), len(mesh.vertices)


class DrawBudget:
    """The triangles and vertices a scene draws so far, against :data:`MAX_SCENE_TRIANGLES`
    and :data:`MAX_SCENE_VERTICES`; ``files`` holds what each mesh file draws, once known."""

    def __init__(self) -> None:
        self.triangles = 0
        self.vertices = 0
        self.files: dict[Path, tuple[int, int]] = {}

    def check(self, triangles: int, vertices: int, fail: Fail) -> None:
        """Fail unless the scene can draw ``triangles`` and ``vertices`` more."""
        for total, most, what in ((self.triangles + triangles, MAX_SCENE_TRIANGLES, "triangles"),
                                  (self.vertices + vertices, MAX_SCENE_VERTICES, "vertices")):
            if total > most:
                fail(f"brings the scene to {total:,} {what}, counting every entry, every "
                     f"placement of a glTF mesh by its nodes and every walker; a scene may "
                     f"draw at most {most:,}")

    def add(self, triangles: int, vertices: int, fail: Fail) -> None:
        """Count ``triangles`` and ``vertices`` more, failing where they pass the totals."""
        self.check(triangles, vertices, fail)
        self.triangles += triangles
        self.vertices += vertices

    def count_ahead(self, data: Mapping[str, Any], base_dir: Path,
                    fail_at: Callable[[str, int, str, str], NoReturn]) -> None:
        """Refuse, before any mesh is built, a scene whose entries are already known to draw
        more than a scene may; ``fail_at(kind, index, key, problem)`` names the entry that
        passes the total. An entry whose count is not known yet (a bad one included: the
        loader reports it in file order) counts nothing here."""
        ahead = DrawBudget()
        by_name: dict[str, tuple[Path, tuple[int, int]] | None] = {}
        for kind in ENTRY_KINDS:
            entries = data.get(kind)
            for index, entry in enumerate(entries if isinstance(entries, list) else []):
                shape = entry.get("shape") if isinstance(entry, dict) else None
                relative = entry.get("file") if shape == "mesh" else None
                if isinstance(shape, str) and shape in _NOMINAL:
                    key, counts = "shape", shape_draw(shape)
                elif isinstance(relative, str):
                    if relative not in by_name:
                        by_name[relative] = known_draw(relative, base_dir)
                    if by_name[relative] is None:
                        continue
                    path, counts = by_name[relative]
                    self.files[path] = counts
                    key = "file"
                else:
                    continue
                ahead.add(*counts, partial(fail_at, kind, index, key))

    def mesh_file(self, relative: str, base_dir: Path, label: str,
                  fail: Fail) -> trimesh.Trimesh:
        """:func:`~game.scene.mesh_files.load_mesh_file`, refused before it is read where what
        the file draws (counted ahead, or loaded for an earlier entry) passes the totals."""
        path = inside(base_dir, relative, fail)
        if path in self.files:
            self.check(*self.files[path], fail)
        mesh = load_mesh_file(relative, base_dir, label, fail)
        self.files[path] = (len(mesh.faces), len(mesh.vertices))
        return mesh
