"""Imports run one way: scene and gpu at the bottom, then shadows and soft, then render, then
app, bench and the command line. A module may import its own subpackage and the layers below."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import ROOT

# Subpackage (or base module) -> layer; a module may import only lower layers and its own unit.
LAYERS = {
    "game.errors": 0, "game.transforms": 0, "game.data": 0, "game.gltf": 0,
    "game.scene": 1, "game.gpu": 1, "game.reference": 1,
    "game.shadows": 2, "game.soft": 2,
    "game.render": 3,
    "game.app": 4,
    "game.bench": 5,
    "game.cli": 6, "game.__main__": 7,
}


def unit(module: str) -> str:
    """The subpackage or base module that ``module`` belongs to."""
    parts = module.split(".")
    return ".".join(parts[:2])


def imported_modules(source: str, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, module) of every import of a ``game`` module in ``source``, relative ones
    resolved against ``module``."""
    package = module if is_package else module.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")
                parent = parent[:len(parent) - node.level + 1]
                base = ".".join(parent + ([base] if base else []))
            names = [f"{base}.{a.name}" if base == "game" else base for a in node.names]
            found += [(node.lineno, name) for name in names]
    return [(line, name) for line, name in found if name == "game" or name.startswith("game.")]


def upward_imports(source: str, module: str, is_package: bool = False) -> list[str]:
    """Each import of ``source`` (the text of ``module``) that breaks the layering."""
    own = unit(module)
    bad = []
    for line, name in imported_modules(source, module, is_package):
        target = unit(name)
        if target == own:
            continue
        if target not in LAYERS:
            bad.append(f"{module}:{line} imports {name}, a module in no layer")
        elif LAYERS[target] >= LAYERS[own]:
            bad.append(f"{module}:{line} imports {name} (layer {LAYERS[target]}) from layer "
                       f"{LAYERS[own]}")
    return bad


def modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted((ROOT / "game").rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        out.append((".".join(parts), path))
    return out


def test_every_module_is_in_a_layer():
    missing = [name for name, _ in modules()
               if unit(name) not in LAYERS and name != "game.__init__"]
    assert not missing


@pytest.mark.parametrize("name, path", modules(), ids=[m for m, _ in modules()])
def test_no_module_imports_from_a_layer_above_it(name, path):
    is_package = path.name == "__init__.py"
    module = name.removesuffix(".__init__")
    if module == "game":
        return
    assert upward_imports(path.read_text(), module, is_package) == []


def test_the_check_finds_an_upward_import():
    assert upward_imports("from game.render import Renderer\n", "game.shadows.fit")
    assert upward_imports("from ..app import capture\n", "game.render.shadow_pass")
    assert upward_imports("import game.bench.runner\n", "game.app.capture")
    # Sideways, between units of one layer, is upward too.
    assert upward_imports("from game.soft import tracer\n", "game.shadows.registry")
    assert not upward_imports("from game.scene import Scene\n", "game.render.renderer")
    assert not upward_imports("from . import plan\n", "game.shadows.registry")
