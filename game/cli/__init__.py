"""The command line (docs/reference.md, section 2): parse, run, and turn every failure into one
line.

Exit status: 0 success; 1 a bad scene or a machine that cannot run it; 2 a bad argument;
130 interrupted (143 SIGTERM, 129 SIGHUP). Set SHADOWGAME_DEBUG=1 to see the traceback of an
internal error. The top of the package: it may import every other layer.
"""

from __future__ import annotations

import logging
import os
import warnings

from game.app import interrupts
from game.cli.arguments import ArgumentError, build_parser
from game.cli.commands import COMMANDS, cmd_default, say
from game.errors import GameError
from game.gpu.timing import THREAD_CLOCK


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings (a mesh lost degenerate triangles) as one line, without the source line."""
    say(f"warning: {message}", err=True)


class _OneLineLog(logging.Handler):
    """Library log records (trimesh's) as one escaped ``warning:`` line each."""

    def emit(self, record: logging.LogRecord) -> None:
        say(f"warning: {' '.join(record.getMessage().split())}", err=True)


def main(argv: list[str] | None = None) -> int:
    warnings.showwarning = _one_line_warning
    log = logging.getLogger("trimesh")
    log.handlers[:] = [_OneLineLog(logging.WARNING)]
    log.propagate = False
    interrupts.install()
    try:
        interrupts.check()  # a signal that came while the program loaded
        return _run(argv)
    except KeyboardInterrupt:  # in the moment between a command's end and the next line
        return _stopped()
    finally:
        interrupts.finish()


def _run(argv: list[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if getattr(args, "clock", None) == THREAD_CLOCK:
            # Read by llvmpipe when the GL starts, which is after this.
            os.environ["LP_NUM_THREADS"] = "0"
        if args.command is None:
            return cmd_default()
        return COMMANDS[args.command](args)
    except ArgumentError as exc:
        say(f"error: {exc}", err=True)
        return 2
    except GameError as exc:
        say(f"error: {exc}", err=True)
        return 1
    except KeyboardInterrupt:
        return _stopped()
    except OSError as exc:  # a full disk, a read-only folder, a path that is a folder
        if interrupts.pending():
            return _stopped()
        where = f"{exc.filename}: " if exc.filename else ""
        say(f"error: {where}{exc.strerror or exc}", err=True)
        return 1
    except Exception as exc:  # noqa: BLE001 - the one place that turns bugs into one line too
        if interrupts.pending():  # Ctrl-C that a library turned into another exception
            return _stopped()
        if os.environ.get("SHADOWGAME_DEBUG"):
            raise
        first = str(exc).splitlines()[0] if str(exc) else ""
        say(f"internal error: {type(exc).__name__}: {first} (set SHADOWGAME_DEBUG=1 for the "
            "traceback)", err=True)
        return 1


def _stopped() -> int:
    line, status = interrupts.stopped_by()
    say(line, err=True)
    return status
