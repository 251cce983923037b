"""Checks and output shared by the subcommands: one printed line, the command line as typed,
output paths checked before any work."""

from __future__ import annotations

import os
import shlex
import sys
from pathlib import Path

from game.app import outputs
from game.cli.values import ArgumentError
from game.errors import printable


def say(line: str, err: bool = False) -> None:
    """Print one line, user-supplied strings in it escaped (game/errors.py)."""
    print(printable(line), file=sys.stderr if err else sys.stdout)


def command_line() -> str:
    """This process's command line as a user would type it again (recorded in run.json)."""
    prog = Path(sys.argv[0]).name if sys.argv else ""
    head = ["python", "-m", "game"] if prog in ("", "__main__.py", "-c") else [prog]
    return shlex.join(head + sys.argv[1:])


def check_out(path: Path | None, flag: str = "--out") -> None:
    """An output folder: a folder, or a path where one can be made (checked before any work)."""
    if path is None:
        return
    if path.exists() and not path.is_dir():
        raise ArgumentError(f"{flag} {path}: exists and is not a folder")
    existing = next((p for p in (path, *path.parents) if p.exists()), Path("."))
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise ArgumentError(f"{flag} {path}: cannot make or write a folder in {existing}")
    problem = outputs.write_problem(existing)
    if problem is not None:
        raise ArgumentError(f"{flag} {path}: cannot make or write a folder in {existing} "
                            f"({problem})")


def check_file(flag: str, path: Path | None) -> None:
    """An output file: in an existing folder that can be written (checked before any work)."""
    if path is None:
        return
    if path.is_dir():
        raise ArgumentError(f"{flag} {path}: is a folder")
    if path.exists() and not (path.is_file() or path.is_char_device() or path.is_fifo()):
        raise ArgumentError(f"{flag} {path}: not a regular file, a device or a pipe")
    folder = path.parent
    if not folder.is_dir():
        raise ArgumentError(f"{flag} {path}: folder {folder} does not exist")
    problem = (outputs.write_problem(folder) if os.access(folder, os.W_OK | os.X_OK)
               else "no permission")
    if problem is not None:
        raise ArgumentError(f"{flag} {path}: cannot write in {folder} ({problem})")
