"""The arrays of a ``frame_kkkk.npz`` dump (docs/reference.md section 3): the kind of numbers
each holds and its shape, checked from each array's header before any array is used.

A dump is a file anyone can hand to ``verify``: a ``lit`` of dates or of text would otherwise
reach the arithmetic and fail there, far from the array that caused it.
"""

from __future__ import annotations

import numpy as np

# numpy's dtype kinds: f floating point, i and u whole numbers, U text.
_FLOAT, _WHOLE, _TEXT, _NUMBER = "f", "iu", "U", "fiu"
_KIND_WORDS = {_FLOAT: "floating-point numbers", _WHOLE: "whole numbers", _TEXT: "text",
               _NUMBER: "a number"}

# Each known array: its dtype kinds, and its shape as a function of the frame's (H, W) and of
# its own declared shape (the layers of lit_lights, the count of names), with how the
# format writes it.
_PIXELS = "(H, W)"
FORMAT = {
    "position": (_FLOAT, lambda h, w, s: s == (h, w, 3), "(H, W, 3)"),
    "normal": (_FLOAT, lambda h, w, s: s == (h, w, 3), "(H, W, 3)"),
    "object": (_WHOLE, lambda h, w, s: s == (h, w), _PIXELS),
    "lit": (_FLOAT, lambda h, w, s: s == (h, w), _PIXELS),
    "soft": (_FLOAT, lambda h, w, s: s == (h, w), _PIXELS),
    "lit_lights": (_FLOAT, lambda h, w, s: len(s) == 3 and s[:2] == (h, w), "(H, W, lights)"),
    "view": (_FLOAT, lambda h, w, s: s == (4, 4), "(4, 4)"),
    "proj": (_FLOAT, lambda h, w, s: s == (4, 4), "(4, 4)"),
    "size": (_WHOLE, lambda h, w, s: s == (2,), "(2,)"),
    "time": (_NUMBER, lambda h, w, s: s == (), "one value"),
    "names": (_TEXT, lambda h, w, s: len(s) == 1, "a list"),
    "scene": (_TEXT, lambda h, w, s: s == (), "one string"),
    "scene_sha256": (_TEXT, lambda h, w, s: s == (), "one string"),
    "scene_path": (_TEXT, lambda h, w, s: s == (), "one string"),
}


def format_problem(key: str, shape: tuple[int, ...], dtype: np.dtype, w: int, h: int
                   ) -> str | None:
    """What is wrong with array ``key`` of a ``w`` x ``h`` frame's dump declared as ``shape``
    of ``dtype``; None when it is what the format says (or an array the format does not name,
    which nothing reads)."""
    if key not in FORMAT:
        return None
    kinds, shape_ok, written = FORMAT[key]
    if dtype.kind in kinds and shape_ok(h, w, shape):
        return None
    if key == "names" and shape == (0,):  # numpy stores an empty list as floats
        return None
    return (f"array {key!r} is {shape} of {dtype}; a dump's {key!r} is {written} of "
            f"{_KIND_WORDS[kinds]}")


REQUIRED_TO_SCORE = ("position", "normal", "lit")


def missing_to_score(files: list[str]) -> str | None:
    """The first array that scoring a frame needs and the dump lacks; None when it has all."""
    return next((key for key in REQUIRED_TO_SCORE if key not in files), None)
