"""The command line (docs/reference.md, section 2): parse, run, and turn every failure into one
line.

Exit status: 0 success; 1 a bad scene or a machine that cannot run it; 2 a bad argument;
130 interrupted. Set SHADOWGAME_DEBUG=1 to see the traceback of an internal error. The top of
the package: it may import every other layer.
"""

from __future__ import annotations

import os
import sys
import warnings

from game.app import interrupts
from game.cli.arguments import ArgumentError, build_parser
from game.cli.commands import COMMANDS, cmd_default
from game.errors import GameError


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings (a mesh lost degenerate triangles) as one line, without the source line."""
    print(f"warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    warnings.showwarning = _one_line_warning
    interrupts.install()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            return cmd_default()
        return COMMANDS[args.command](args)
    except ArgumentError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except GameError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the one place that turns bugs into one line too
        if interrupts.pending():  # Ctrl-C that a library turned into another exception
            print("interrupted", file=sys.stderr)
            return 130
        if os.environ.get("SHADOWGAME_DEBUG"):
            raise
        first = str(exc).splitlines()[0] if str(exc) else ""
        print(f"internal error: {type(exc).__name__}: {first} (set SHADOWGAME_DEBUG=1 for the "
              "traceback)", file=sys.stderr)
        return 1
