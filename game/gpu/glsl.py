"""The shader preprocessor: ``#define``s after ``#version`` and ``#include`` with a depth limit.

Shader sources live in ``shaders/``; the block declarations are generated includes
(``blocks/*.glsl``, from game/gpu/blocks.py). Values reach GLSL only through :func:`build`'s
``defines``, never through string formatting of GLSL code. Pure string work, unit-tested
without GL.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping

from game.data import SHADER_DIR
from game.gpu.blocks import GENERATED

MAX_INCLUDE_DEPTH = 8

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_VERSION = re.compile(r"^\s*#\s*version\b")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class ShaderSourceError(ValueError):
    """A shader that cannot be assembled: missing file, bad define, include loop."""


def _define_value(name: str, value: object) -> str:
    if not _NAME.match(name):
        raise ShaderSourceError(f"bad #define name {name!r}")
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if value != value or value in (float("inf"), float("-inf")):
            raise ShaderSourceError(f"#define {name} has a non-finite value {value}")
        return repr(value) if ("." in repr(value) or "e" in repr(value)) else f"{value}.0"
    raise ShaderSourceError(f"#define {name} needs a bool, int or float, got {value!r}")


def preprocess(source: str, defines: Mapping[str, object] | None = None,
               read: Callable[[str], str] | None = None, name: str = "<shader>") -> str:
    """Resolve includes, then insert ``defines`` right after the ``#version`` line.

    Parameters
    ----------
    source
        The shader text; it must start (after blank lines or comments) with ``#version``.
    defines
        Names to values (bool, int, float). A ``None`` value is an error, so a forgotten setting
        fails here instead of compiling with a default.
    read
        Returns the text of an included file by its name; defaults to reading ``shaders/``.
    """
    read = read or _read_shader_file
    text = _resolve(source, read, name, depth=0)
    lines = text.split("\n")
    index = next((i for i, line in enumerate(lines) if _VERSION.match(line)), None)
    if index is None:
        raise ShaderSourceError(f"{name}: no #version line")
    inserted = [f"#define {key} {_define_value(key, val)}" for key, val in (defines or {}).items()]
    return "\n".join(lines[: index + 1] + inserted + lines[index + 1:])


def _resolve(source: str, read: Callable[[str], str], name: str, depth: int) -> str:
    if depth > MAX_INCLUDE_DEPTH:
        raise ShaderSourceError(f"{name}: includes nested deeper than {MAX_INCLUDE_DEPTH} "
                                "(an include loop?)")
    out = []
    for number, line in enumerate(source.split("\n"), start=1):
        match = _INCLUDE.match(line)
        if match is None:
            out.append(line)
            continue
        included = match.group(1)
        try:
            text = read(included)
        except (OSError, KeyError) as exc:
            raise ShaderSourceError(
                f"{name}:{number}: cannot include {included!r} ({exc})") from None
        out.append(_resolve(text, read, included, depth + 1))
    return "\n".join(out)


def _read_shader_file(name: str) -> str:
    if name in GENERATED:
        return GENERATED[name]
    path = (SHADER_DIR / name).resolve()
    if SHADER_DIR not in path.parents:
        raise OSError(f"{name} is outside {SHADER_DIR}")
    return path.read_text()


def build(file_name: str, defines: Mapping[str, object] | None = None) -> str:
    """Read ``shaders/<file_name>`` and preprocess it."""
    try:
        source = _read_shader_file(file_name)
    except OSError as exc:
        raise ShaderSourceError(f"cannot read shader {file_name!r} ({exc})") from None
    return preprocess(source, defines, name=file_name)
