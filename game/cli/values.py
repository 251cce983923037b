"""Command-line values: the types that check a flag's value and the one error they raise.

A bad value becomes one :class:`ArgumentError` line (exit status 2), never argparse's usage
block.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from game.errors import GameError

MAX_SIZE = 16384
DEFAULT_OUT = Path("captures")  # runs write to DEFAULT_OUT/<scene folder name>/ by default


class ArgumentError(GameError):
    """A bad command-line value."""


def path_value(text: str) -> Path:
    """A file or folder to write or read: not empty (``Path("")`` is the current folder, which
    a user who typed nothing there did not mean)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; name a file or folder")
    return Path(text)


def size_value(text: str) -> tuple[int, int]:
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WxH, like 960x540, got {text!r}") from None
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise argparse.ArgumentTypeError(f"size must be 1..{MAX_SIZE} per side, got {text!r}")
    return w, h


def _int(text: str) -> int:
    """``int(text)``, with a number too long for Python to read said so."""
    try:
        return int(text)
    except ValueError:
        if text.strip().lstrip("+-").isdigit():
            raise argparse.ArgumentTypeError(f"a whole number of {len(text.strip())} digits is "
                                             "too long to read") from None
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def positive_int(text: str) -> int:
    value = _int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


# Scene times stay where float32 (the shaders' time) still counts milliseconds apart.
MAX_SCENE_TIME = 1e9
FPS_RANGE = (1e-3, 1e6)


def at_most(most: float, kind=positive_int):
    """A ``kind`` value (positive_int or positive) no larger than ``most``."""
    def parse(text: str):
        value = kind(text)
        if value > most:
            raise argparse.ArgumentTypeError(f"must be at most {most:g}, got {text!r}")
        return value
    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


def positive(text: str) -> float:
    value = finite(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def in_range(low: float, high: float, shown: bool = False):
    """A finite number from ``low`` to ``high`` (``shown``: the bounds end its help)."""
    def parse(text: str) -> float:
        value = finite(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be {low:g}..{high:g}, got {text!r}")
        return value
    parse.__name__ = "number"  # argparse names the type in its messages
    if shown:
        parse.bounds = f"{low:g}..{high:g}"
    return parse


def whole(low: int, high: int):
    """A whole number from ``low`` to ``high``; the bounds end its help."""
    def parse(text: str) -> int:
        value = _int(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be {low}..{high}, got {text!r}")
        return value
    parse.__name__, parse.bounds = "whole number", f"{low}..{high}"
    return parse


def unit(text: str) -> float:
    value = finite(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {text!r}")
    return value


scene_time = in_range(-MAX_SCENE_TIME, MAX_SCENE_TIME)
frame_rate = in_range(*FPS_RANGE)
# A map narrower than 16 texels has no texel left inside its margins; one side past the GL's
# GL_MAX_TEXTURE_SIZE is clamped to it with a note, so the top only keeps the number sane.
map_side = whole(16, 1_000_000)
# Biases and texel ratios past these reach float32's range in the shaders' blocks.
bias_texels = in_range(0.0, 1000.0, shown=True)
