"""House rules, read from the source with ``ast`` and a brace scan, never by importing it.

- Code stays in pieces a reader can hold: no file under ``game/`` or ``shaders/`` over
  MAX_FILE_LINES lines, no class over MAX_CLASS_LINES, no function over MAX_FUNCTION_LINES
  unless the line right above it (above its decorators) is a comment ``# long: <reason>`` in
  Python or ``// long: <reason>`` in GLSL.
- Tests stand alone: no file under ``tests/`` imports a test module (``test_*``), ``conftest``
  or anything relative; shared code lives in helper modules (tests/helpers.py and the
  ``*_helpers.py``, ``*_driver.py`` and other non-test modules beside them) and fixtures in
  tests/conftest.py. Tests reach ``game`` through its public names only: no private name (one
  starting with ``_``) of a ``game`` module is imported, read or patched.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GAME = ROOT / "game"
SHADERS = ROOT / "shaders"
TESTS = ROOT / "tests"

MAX_FILE_LINES = 450
MAX_CLASS_LINES = 300
MAX_FUNCTION_LINES = 80


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)


# -- Python sizes -------------------------------------------------------------------------------
def python_size_offenders(path: Path, text: str | None = None) -> list[str]:
    """Each way ``path`` (or ``text``, named by ``path``) breaks the size rules."""
    text = path.read_text() if text is None else text
    lines = text.splitlines()
    name = _rel(path)
    found = []
    if len(lines) > MAX_FILE_LINES:
        found.append(f"{name}: {len(lines)} lines, more than {MAX_FILE_LINES}")
    for node in ast.walk(ast.parse(text)):
        if not isinstance(node, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        first = min([node.lineno] + [d.lineno for d in node.decorator_list])
        length = node.end_lineno - first + 1
        if isinstance(node, ast.ClassDef):
            if length > MAX_CLASS_LINES:
                found.append(f"{name}:{node.lineno}: class {node.name} is {length} lines, "
                             f"more than {MAX_CLASS_LINES}")
            continue
        above = lines[first - 2].strip() if first >= 2 else ""
        if length > MAX_FUNCTION_LINES and not re.match(r"# long:\s*\S", above):
            found.append(f"{name}:{node.lineno}: {node.name}() is {length} lines, more than "
                         f"{MAX_FUNCTION_LINES} (split it, or say why not in a '# long:' "
                         "comment above it)")
    return found


def test_python_files_classes_and_functions_stay_short():
    offenders = [o for path in sorted(GAME.rglob("*.py")) for o in python_size_offenders(path)]
    assert not offenders, "\n".join(offenders)


# -- GLSL sizes ---------------------------------------------------------------------------------
def _blank_comments(text: str) -> str:
    """``text`` with comments and preprocessor lines blanked, newlines kept (line numbers hold)."""
    def blank(match: re.Match) -> str:
        return re.sub(r"[^\n]", " ", match.group(0))

    text = re.sub(r"/\*.*?\*/|//[^\n]*", blank, text, flags=re.S)
    return re.sub(r"^[ \t]*#[^\n]*", blank, text, flags=re.M)


FUNCTION_HEAD = re.compile(r"^\s*(?:\w+\s+)*\w+(?:\s*\[\s*\w*\s*\])?\s+(\w+)\s*\([^{};]*\)\s*$",
                           re.S)


def glsl_functions(text: str) -> list[tuple[str, int, int]]:
    """(name, first line, last line) of every top-level ``type name(...) { ... }`` block."""
    code = _blank_comments(text)
    found = []
    depth, head_start, i = 0, 0, 0
    while i < len(code):
        char = code[i]
        if depth == 0 and char in ";}":
            head_start = i + 1
        elif char == "{":
            if depth == 0:
                head = code[head_start:i]
                match = FUNCTION_HEAD.match(head)
                if match:
                    start = head_start + len(head) - len(head.lstrip())
                    close = _closing_brace(code, i)
                    found.append((match.group(1), code.count("\n", 0, start) + 1,
                                  code.count("\n", 0, close) + 1))
                    i, head_start = close + 1, close + 1
                    continue
            depth += 1
        elif char == "}":
            depth -= 1
            if depth == 0:
                head_start = i + 1
        i += 1
    return found


def _closing_brace(code: str, opening: int) -> int:
    depth = 0
    for k in range(opening, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(code) - 1


def shader_size_offenders(path: Path, text: str | None = None) -> list[str]:
    text = path.read_text() if text is None else text
    lines = text.splitlines()
    name = _rel(path)
    found = []
    if len(lines) > MAX_FILE_LINES:
        found.append(f"{name}: {len(lines)} lines, more than {MAX_FILE_LINES}")
    for function, first, last in glsl_functions(text):
        length = last - first + 1
        above = lines[first - 2].strip() if first >= 2 else ""
        if length > MAX_FUNCTION_LINES and not re.match(r"// long:\s*\S", above):
            found.append(f"{name}:{first}: {function}() is {length} lines, more than "
                         f"{MAX_FUNCTION_LINES} (split it, or say why not in a '// long:' "
                         "comment above it)")
    return found


def test_shader_files_and_functions_stay_short():
    offenders = [o for path in sorted(p for p in SHADERS.rglob("*") if p.is_file())
                 for o in shader_size_offenders(path)]
    assert not offenders, "\n".join(offenders)


# -- tests stand alone --------------------------------------------------------------------------
def _is_test_module(dotted: str) -> bool:
    last = dotted.rsplit(".", 1)[-1]
    return last.startswith("test_") or last == "conftest"


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _game_module(dotted: str) -> bool:
    """Whether ``dotted`` names a module or package of ``game`` (a file, not a name in one)."""
    if dotted != "game" and not dotted.startswith("game."):
        return False
    base = ROOT.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _is_game_module_expr(node: ast.expr, game_modules: set[str]) -> bool:
    """Whether ``node`` is a name (or dotted path) bound to a ``game`` module."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return False
    if not parts:
        return node.id in game_modules or node.id == "game"
    return node.id == "game" and _game_module(".".join(["game", *reversed(parts)]))


def import_offenders(path: Path, text: str | None = None) -> list[str]:
    """Each import of a test module or of a private ``game`` name in ``path`` (or ``text``)."""
    tree = ast.parse(path.read_text() if text is None else text)
    name = _rel(path)
    found = []
    game_modules: set[str] = set()   # local names bound to game modules
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith(("tests.", "test_")) or alias.name == "conftest":
                    if _is_test_module(alias.name):
                        found.append(f"{name}:{node.lineno}: imports the test module "
                                     f"{alias.name}")
                if _game_module(alias.name):
                    if any(_private(part) for part in alias.name.split(".")):
                        found.append(f"{name}:{node.lineno}: imports the private module "
                                     f"{alias.name}")
                    if alias.asname:
                        game_modules.add(alias.asname)
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                found.append(f"{name}:{node.lineno}: relative import "
                             f"{'.' * node.level}{module}")
                continue
            if module in ("tests", "conftest") or module.startswith(("tests.", "test_")):
                targets = [f"{module}.{a.name}" for a in node.names
                           if (TESTS.parent.joinpath(*module.split("."), a.name + ".py")
                               .is_file())] or [module]
                for target in targets:
                    if _is_test_module(target):
                        found.append(f"{name}:{node.lineno}: imports from the test module "
                                     f"{target}")
            if module == "game" or module.startswith("game."):
                for alias in node.names:
                    if _private(alias.name) or any(_private(p) for p in module.split(".")):
                        found.append(f"{name}:{node.lineno}: imports the private name "
                                     f"{module}.{alias.name}")
                    elif _game_module(f"{module}.{alias.name}"):
                        game_modules.add(alias.asname or alias.name)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and _private(node.attr)
                and _is_game_module_expr(node.value, game_modules)):
            found.append(f"{name}:{node.lineno}: uses the private name {node.attr} of a game "
                         "module")
        elif isinstance(node, ast.Call) and node.args:
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if called not in ("setattr", "getattr", "delattr", "hasattr"):
                continue
            target = node.args[0]
            if (len(node.args) > 1 and isinstance(node.args[1], ast.Constant)
                    and isinstance(node.args[1].value, str) and _private(node.args[1].value)
                    and _is_game_module_expr(target, game_modules)):
                found.append(f"{name}:{node.lineno}: {called}() on the private name "
                             f"{node.args[1].value} of a game module")
            elif (isinstance(target, ast.Constant) and isinstance(target.value, str)
                  and target.value.startswith("game.")
                  and any(_private(p) for p in target.value.split("."))):
                found.append(f"{name}:{node.lineno}: {called}() on the private name "
                             f"{target.value}")
    return sorted(found, key=lambda line: int(line.split(":")[1]))


def test_tests_import_no_test_module_and_no_private_game_name():
    offenders = [o for path in sorted(TESTS.rglob("*.py")) for o in import_offenders(path)]
    assert not offenders, "\n".join(offenders)


# -- the checks themselves ----------------------------------------------------------------------
def test_a_long_function_is_found_unless_a_long_comment_says_why():
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    text = f"def short():\n    pass\n\n\n@decorated\ndef long_one():\n{body}"
    assert [o.split(": ", 1)[1][:20] for o in python_size_offenders(Path("x.py"), text)] == [
        "long_one() is 82 lin"]
    excused = f"# long: one table, read top to bottom\n@decorated\ndef long_one():\n{body}"
    assert python_size_offenders(Path("x.py"), excused) == []
    assert python_size_offenders(Path("x.py"), f"# long:\ndef long_one():\n{body}")


def test_glsl_functions_are_found_by_their_braces():
    text = """#version 430
layout(std430, binding = 0) buffer Data { uint values[]; };
struct Pair { int a; int b; };
// a comment with braces { and a call( )
float helper(vec3 p, float k) {
    if (k > 0.0) { return p.x; }
    return k;
}

void main()
{
    for (int i = 0; i < 3; i++) { values[i] = 0u; }
}
"""
    assert glsl_functions(text) == [("helper", 5, 8), ("main", 10, 13)]
    body = "".join(f"    x += {i}.0;\n" for i in range(MAX_FUNCTION_LINES))
    long_one = f"float f() {{\n    float x = 0.0;\n{body}    return x;\n}}\n"
    assert len(shader_size_offenders(Path("a.glsl"), long_one)) == 1
    assert shader_size_offenders(Path("a.glsl"), "// long: one unrolled loop\n" + long_one) == []


def test_imports_of_test_modules_and_private_names_are_found():
    text = """
from tests.helpers import ROOT
from tests import shadow_check
from tests.cli.cli_helpers import run
from tests.cli.test_cli import run
from tests import test_docs
from tests.conftest import TINY
from .neighbour import thing
import conftest
from game.soft import grid
from game.soft.grid import SceneGrid, _secret
from game.soft import binning as b
import game.soft.tracer as tracer

grid.SceneGrid, grid._cell, b._hidden, tracer._x, game.soft.grid._y, SceneGrid._not_a_module
game.soft.grid.SceneGrid._not_a_module_either
monkeypatch.setattr(grid, "_flag", True)
monkeypatch.setattr("game.soft.grid._flag", True)
monkeypatch.setattr(grid, "public", True)
"""
    found = [o.split(": ", 1)[1] for o in import_offenders(TESTS / "x.py", text)]
    assert found == [
        "imports from the test module tests.cli.test_cli",
        "imports from the test module tests.test_docs",
        "imports from the test module tests.conftest",
        "relative import .neighbour",
        "imports the test module conftest",
        "imports the private name game.soft.grid._secret",
        "uses the private name _cell of a game module",
        "uses the private name _hidden of a game module",
        "uses the private name _x of a game module",
        "uses the private name _y of a game module",
        "setattr() on the private name _flag of a game module",
        "setattr() on the private name game.soft.grid._flag",
    ]
