"""Every numeric flag at its extremes: 0, negative, tiny, huge, NaN and infinity.

Each value is parsed (game/cli/arguments.py); one the parser accepts is run in process at 16x9
(capture and trace), with the method that reads the flag. Either way a user sees a successful
run or one line and a non-zero exit: never an internal error, a traceback or numpy's warnings.
Values out of a flag's bounds fail at parse time, so the walk stays quick.
"""

from __future__ import annotations

import argparse
import math
import re
import warnings

import pytest

from game.cli import arguments
from game.errors import GameError
from tests.cli.cli_helpers import run_main
from tests.helpers import TINY

VALUES = ["0", "-1", "1", "3", "1e-300", "1e308", "99999999999999999999999", "nan", "inf",
          "-inf"]
SIZES = ["0x0", "-1x9", "1x1", "99999x9", "nanxnan"]

# The method that reads a flag, where the default (clumped) does not.
METHOD_OF = {"--single-resolution": ["--method", "single"],
             "--lamp-resolution": ["--method", "single"],
             "--cascades": ["--method", "csm"], "--cascade-lambda": ["--method", "csm"],
             "--cascade-resolution": ["--method", "csm"],
             "--max-clump-resolution": ["--view-resolution"]}
# Run only what capture and trace render; play opens a window and bench sweeps for minutes:
# their flags are checked at parse time, and they share capture's types.
RUN = ("capture", "trace")


def _numeric_flags(command: str) -> list[tuple[str, argparse.Action]]:
    parser = arguments.build_parser()._command_parser(command)
    return [(a.option_strings[-1], a) for a in parser._actions
            if a.option_strings and a.type not in (None, arguments.path_value)
            and a.option_strings[-1].startswith("--")]


def _parse(command: str, flag: str, value: str):
    extra = ["--report"] if command == "bench" and flag == "--never" else []
    try:
        return arguments.build_parser().parse_args([command, f"{flag}={value}", *extra]), None
    except GameError as exc:
        return None, str(exc)


CASES = [(command, flag, value)
         for command in ("capture", "trace", "bench", "play")
         for flag, action in _numeric_flags(command)
         for value in (SIZES if action.type is arguments.size_value else VALUES)]


def test_the_walk_covers_the_shadow_and_tracer_flags():
    flags = {flag for command, flag, _ in CASES}
    for flag in ("--clump-resolution", "--depth-bias", "--normal-bias", "--slope-bias",
                 "--cascades", "--samples", "--warmup", "--render-scale", "--size", "--fps"):
        assert flag in flags, flag


def _check_one(capsys, tmp_path, command, flag, value) -> str | None:
    """What is wrong with ``flag=value`` (None when nothing is)."""
    args, message = _parse(command, flag, value)
    if message is not None:
        return None if "\n" not in message and flag in message else f"message {message!r}"
    parsed = getattr(args, flag[2:].replace("-", "_"))
    numbers = parsed if isinstance(parsed, tuple) else (parsed,)
    if value in ("nan", "inf", "-inf") or not all(abs(float(n)) < math.inf for n in numbers):
        return f"accepted as {parsed!r}"
    if command not in RUN or flag in ("--frames", "--size", "--time", "--fps"):
        return None  # the frame options are checked in tests/cli/test_bad_input.py
    with warnings.catch_warnings():
        warnings.simplefilter("always", RuntimeWarning)  # every run shows numpy's, not one
        code, lines = run_main(capsys, command, TINY, "--size", "16x9", "--out",
                               tmp_path / "out", *METHOD_OF.get(flag, []), f"{flag}={value}")
    if code != 0 and len(lines) != 1:
        return f"exit {code} with {lines}"
    if any(not line.startswith(("note: ", "error: ")) for line in lines):
        return f"exit {code} with {lines}"
    return None


@pytest.mark.parametrize("command", ["capture", "trace", "bench", "play"])
def test_numeric_flags_at_their_extremes(capsys, tmp_path, command):
    wrong = [f"{flag}={value}: {problem}" for cmd, flag, value in CASES if cmd == command
             for problem in [_check_one(capsys, tmp_path, command, flag, value)] if problem]
    assert not wrong, "\n".join(wrong)


def test_the_bounds_are_in_the_help():
    text = arguments.build_parser()._command_parser("capture").format_help()
    for flag in ("--clump-resolution", "--character-resolution", "--depth-bias",
                 "--normal-bias", "--slope-bias", "--character-texels-per-pixel"):
        found = re.search(rf"\n\s+{flag} \S+\s+(.*?)(?=\n\s+--)", text, re.S)
        assert found and re.search(r"\d\.\.\d|at least|at most", found.group(1)), flag
