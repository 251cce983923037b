"""Reading one TOML table with typed getters that fail with the table's file and line.

``tomllib`` keeps no positions, so :class:`Locator` finds the line of a table or key by scanning
the raw text. Every failure is a :class:`~game.errors.SceneError` with a one-line message of the
form ``<file>:<line>: <table>.<key>: <problem>``.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from game.errors import SceneError

# The largest magnitude of any number in a scene: positions, sizes and scales in metres, speeds
# in metres per second. Beyond it, float32 positions lose centimetres and products overflow.
MAX_MAGNITUDE = 1e6
# The least size or scale of a shape, a micrometre: far below any shadow's texel, and far above
# the sizes at which float64 underflows and the shape's normals come out NaN.
MIN_LENGTH = 1e-6

# Hints for keys that are common mistakes, where a close-match suggestion would mislead.
KEY_HINTS = {
    ("character", "position"): "characters have no position; give path = [[x, y, z], ...]",
}


_HEADER = re.compile(r"""^\s*(\[\[?)\s*([A-Za-z_"'][^\[\]]*?)\s*\]\]?\s*(#.*)?$""")


def _header_name(raw: str) -> str:
    """The dotted name of a table header with quotes and spaces removed."""
    return ".".join(part.strip().strip("\"'") for part in raw.split("."))


class Locator:
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


class Context:
    """What every check needs to report: the file's label and the line locator."""

    def __init__(self, text: str, source: Path | None, base_dir: Path) -> None:
        self.label = str(source) if source is not None else "<scene>"
        self.locator = Locator(text)
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


def describe(value: Any) -> str:
    """A short repr of a TOML value for messages."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def suggest(word: str, choices: Iterable[str]) -> str:
    """`, did you mean 'x'?` for a near match, or the list of valid choices."""
    choices = list(choices)
    close = difflib.get_close_matches(word, choices, n=1)
    if close:
        return f", did you mean '{close[0]}'?"
    return f" (expected one of: {', '.join(choices)})" if choices else ""


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


class Table:
    """One TOML table being read: typed getters that fail with the table's location."""

    def __init__(self, ctx: Context, name: str, index: int | None, data: Any) -> None:
        self.ctx, self.name, self.index = ctx, name, index
        if not isinstance(data, dict):
            ctx.fail(name, index, None, f"must be a table, got {describe(data)}")
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
            self.fail(key, "unknown key" + suggest(key, allowed))

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
        if not is_number(value):
            self.fail(key, f"must be a number, got {describe(value)}")
        if not (isinstance(value, int) or math.isfinite(value)):
            self.fail(key, f"must be finite, got {value}")
        if not abs(value) <= MAX_MAGNITUDE:  # compared before float(): 400-digit integers
            self.fail(key, f"must be within +-{MAX_MAGNITUDE:g}, got {describe(value)}")
        value = float(value)
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
                or not all(is_number(v) for v in value)):
            self.fail(key, f"must be a list of 3 numbers [x, y, z], got {describe(value)}")
        if not all(isinstance(v, int) or math.isfinite(v) for v in value):
            self.fail(key, f"must be finite, got {value}")
        if not all(abs(v) <= MAX_MAGNITUDE for v in value):
            self.fail(key, f"must be within +-{MAX_MAGNITUDE:g} per component, got "
                           f"{describe(value)}")
        array = np.array(value, dtype=np.float64)
        if positive and np.any(array <= 0.0):
            self.fail(key, f"must be positive, got {value}")
        return array

    def string(self, key: str, choices: Iterable[str] | None = None,
               default: str | None = None) -> str:
        value = self.data.get(key, default) if default is not None else self.require(key)
        if not isinstance(value, str):
            self.fail(key, f"must be a string, got {describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"unknown value '{value}'" + suggest(value, choices))
        return value

    def scale(self, key: str = "scale") -> np.ndarray:
        """A positive number or three positive numbers, as a (3,) array; default 1."""
        value = self.data.get(key, 1.0)
        if is_number(value):
            return self._at_least(key, np.full(3, self._check_number(key, value, positive=True)))
        if isinstance(value, list):
            return self._at_least(key, self._check_vec3(key, value, positive=True))
        self.fail(key, f"must be a number or a list of 3 numbers, got {describe(value)}")

    def length(self, key: str) -> float:
        """A shape's radius or height: a number of at least MIN_LENGTH metres."""
        return float(self._at_least(key, np.array([self.number(key, positive=True)]))[0])

    def lengths(self, key: str) -> np.ndarray:
        """A shape's three sizes: numbers of at least MIN_LENGTH metres, as a (3,) array."""
        return self._at_least(key, self.vec3(key, positive=True))

    def _at_least(self, key: str, values: np.ndarray) -> np.ndarray:
        if float(values.min()) < MIN_LENGTH:
            self.fail(key, f"must be at least {MIN_LENGTH:g}, got {float(values.min()):.3g}")
        return values
