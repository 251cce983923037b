"""The modules of ``game/`` import each other without a cycle, and only downwards between units.

Every module is parsed with ``ast``, never imported, and every import counts: at the top, inside
functions and under ``TYPE_CHECKING``. A cycle that only a function-level or type-checking import
closes still ties its modules into one knot, and the next top-level import along it breaks at
load time.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

GAME = Path(__file__).resolve().parent.parent / "game"

# Unit (a subpackage or base module) -> layer, lowest first, as docs/design/architecture.md
# draws them. A unit may import its own modules and any unit on a lower layer; an import onto
# its own layer from another unit is sideways, and counts as upward.
LAYERS = {
    "game.errors": 0, "game.transforms": 0, "game.data": 0, "game.gltf": 0,
    "game.scene": 1, "game.gpu": 1, "game.reference": 1,
    "game.shadows": 2, "game.soft": 2,
    "game.render": 3,
    "game.app": 4,
    "game.bench": 5,
    "game.cli": 6,
    "game.__main__": 7,
}
# Imports that break the layering today, each with the reason it is let through:
# (importing module, imported module).
KNOWN_UPWARD: dict[tuple[str, str], str] = {}


def module_files(root: Path = GAME) -> dict[str, Path]:
    """Every module under ``root`` by dotted name; a package by its own name."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def known_module(name: str, modules) -> str | None:
    """``name`` or the longest of its parents that is a module of ``modules``."""
    parts = name.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in modules:
            return candidate
        parts.pop()
    return None


def imports_of(source: str, module: str, is_package: bool, modules) -> set[str]:
    """The modules of ``modules`` that ``source`` (the text of ``module``) imports.

    ``from package import name`` imports the submodule ``package.name`` where there is one and
    the package otherwise. A parent package that Python loads on the way to a submodule is not
    an edge: it is already loading when one of its own modules runs.
    """
    package = module if is_package else module.rpartition(".")[0]
    found: set[str | None] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(known_module(alias.name, modules) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(parent + ([base] if base else []))
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                found.add(sub if sub in modules else known_module(base, modules))
    found.discard(None)
    found.discard(module)
    return found  # type: ignore[return-value]


def import_graph(files: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the modules it imports, for every module of ``files``."""
    return {name: imports_of(path.read_text(), name, path.name == "__init__.py", files)
            for name, path in files.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle through each knot of ``graph`` (a strongly connected set of two modules or
    more), as the modules in import order with the first repeated at the end."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    knots: list[set[str]] = []

    def connect(start: str) -> None:
        # Tarjan's algorithm without recursion: a frame is a module and its unvisited edges.
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, edges = work[-1]
            step = next(edges, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = len(index)
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(sorted(graph[step]))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                knot = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    knot.add(member)
                    if member == node:
                        break
                if len(knot) > 1:
                    knots.append(knot)

    for name in sorted(graph):
        if name not in index:
            connect(name)
    return [cycle_in(graph, knot) for knot in knots]


def cycle_in(graph: dict[str, set[str]], knot: set[str]) -> list[str]:
    """A shortest cycle through the first module of ``knot``, by a breadth-first search."""
    start = min(knot)
    came_from: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for step in sorted(graph[node] & knot):
                if step == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(came_from[path[-1]])
                    return [*reversed(path), start]
                if step not in came_from:
                    came_from[step] = node
                    following.append(step)
        frontier = following
    raise AssertionError(f"no cycle through {start} in {sorted(knot)}")


def unit(module: str) -> str:
    """The subpackage or base module that ``module`` belongs to."""
    return ".".join(module.split(".")[:2])


def upward(graph: dict[str, set[str]]) -> list[str]:
    """Each import in ``graph`` onto the importer's own layer or above, from another unit."""
    bad = []
    for module in sorted(graph):
        own = unit(module)
        if own == "game":
            continue
        for target in sorted(graph[module]):
            other = unit(target)
            if other == own or (module, target) in KNOWN_UPWARD:
                continue
            if other not in LAYERS or own not in LAYERS:
                bad.append(f"{module} imports {target}: {own} or {other} is in no layer")
            elif LAYERS[other] >= LAYERS[own]:
                bad.append(f"{module} (layer {LAYERS[own]}) imports {target} "
                           f"(layer {LAYERS[other]})")
    return bad


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    return import_graph(module_files())


def test_no_import_cycle_in_game(graph):
    found = [" -> ".join(cycle) for cycle in cycles(graph)]
    assert not found, "import cycles:\n" + "\n".join(found)


def test_no_import_goes_up_a_layer(graph):
    assert upward(graph) == []


def test_every_unit_has_a_layer(graph):
    assert {unit(m) for m in graph} - {"game"} <= set(LAYERS)


def test_the_known_upward_imports_still_exist(graph):
    gone = [pair for pair in KNOWN_UPWARD if pair[1] not in graph.get(pair[0], set())]
    assert not gone, f"no longer imported, drop them from KNOWN_UPWARD: {gone}"


# -- the checks themselves, on made-up modules ------------------------------------------------
FAKE = {"game.a": "", "game.a.x": "", "game.a.y": "", "game.b": "", "game.b.z": ""}


def fake_graph(sources: dict[str, str]) -> dict[str, set[str]]:
    names = set(FAKE) | set(sources)
    return {name: imports_of(sources.get(name, ""), name, name in ("game.a", "game.b"), names)
            for name in names}


def test_a_cycle_closed_inside_a_function_or_for_type_checking_is_found():
    graph = fake_graph({
        "game.a.x": "from game.a import y\n",
        "game.a.y": "from typing import TYPE_CHECKING\n"
                    "if TYPE_CHECKING:\n    from .x import Thing\n",
    })
    assert cycles(graph) == [["game.a.x", "game.a.y", "game.a.x"]]
    graph = fake_graph({
        "game.a.x": "import game.b.z\n",
        "game.b.z": "def late():\n    from game.a.x import f\n",
    })
    assert cycles(graph) == [["game.a.x", "game.b.z", "game.a.x"]]
    # A package loading its own submodules is no cycle; importing the package back is.
    graph = fake_graph({"game.a": "from .x import f\n", "game.a.x": "from game.a.y import g\n"})
    assert cycles(graph) == []
    graph = fake_graph({"game.a": "from .x import f\n", "game.a.x": "from game.a import g\n"})
    assert cycles(graph) == [["game.a", "game.a.x", "game.a"]]


def test_an_import_up_or_sideways_is_found():
    assert upward({"game.shadows.fit": {"game.render.renderer"}})
    assert upward({"game.shadows.registry": {"game.soft.tracer"}})   # one layer: sideways
    assert upward({"game.render.frame": {"game.nowhere"}})
    assert not upward({"game.render.renderer": {"game.scene.model", "game.render.frame"}})
