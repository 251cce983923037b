"""Every file the program writes goes through here: to a temp file, then renamed into place.

An interrupted run therefore never leaves a truncated frame, dump or stats file behind.
"""

from __future__ import annotations

import errno
import json
import os
import re
import secrets
import stat
import struct
import zlib
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

import numpy as np

from game.app import interrupts
from game.errors import GameError


class WriteError(GameError, OSError):
    """A file that could not be written (a full disk, a quota, a read-only folder), named in
    its one-line message. Still an OSError, for code that handles failed writes as such."""


def _write_error(path: Path, error: OSError) -> WriteError:
    if isinstance(error, WriteError):
        return error
    # Errors from writing to a file descriptor (ENOSPC, EDQUOT, EIO) carry no file name; the
    # temp file's name would mean nothing to the user: name the file being written.
    return WriteError(f"{path}: cannot write: {error.strerror or error}")


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a pipe"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket"))


def check_paths(files: Sequence[Path] = (), folders: Sequence[Path] = ()) -> None:
    """Refuse, before any work, an output that is in the way: one of ``files`` (to be written,
    or read back and rewritten) that exists and is not a regular file, or one of ``folders``
    that exists and is not a folder. A run would otherwise fail only once its work is done, or
    wait for good on a pipe it reads."""
    for path, want_dir in [(f, False) for f in files] + [(d, True) for d in folders]:
        try:
            mode = os.stat(path).st_mode
        except FileNotFoundError:
            continue
        except OSError as error:  # a file where a folder on the way should be, a loop of links
            raise WriteError(f"{path}: cannot be written: {error.strerror}") from None
        if want_dir and not stat.S_ISDIR(mode):
            raise WriteError(f"{path}: exists and is not a folder; move it away or choose "
                             "another --out")
        if not want_dir and not stat.S_ISREG(mode):
            kind = next((word for test, word in _KINDS if test(mode)), "something else")
            raise WriteError(f"{path}: {kind}, not a regular file; move it away or choose "
                             "another --out")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# Temp files are made readable by the owner only; outputs get the usual permissions.
FILE_MODE = 0o666 & ~_umask()


# The open :func:`together` block's (temp, final) pairs; None outside one.
_group: list[tuple[Path, Path]] | None = None


@contextmanager
def together():
    """Files written inside the block appear together or not at all.

    Each file goes to its temp name as usual, but the renames wait for the end of the block and
    run with Ctrl-C held; if anything fails first, every temp file of the block is removed. A
    frame's PNG, NPZ and GLB are written this way, so a frame is whole or absent.
    """
    global _group
    if _group is not None:
        raise RuntimeError("together() blocks do not nest")
    _group = []
    try:
        yield
        with interrupts.deferred():
            for tmp, path in _group:
                try:
                    os.replace(tmp, path)
                except OSError as error:
                    raise _write_error(path, error) from None
    except BaseException:
        for tmp, _path in _group:
            tmp.unlink(missing_ok=True)
        raise
    finally:
        _group = None


# The temp names atomic_file makes: ``.NAME.PID.HEX.tmp``.
TEMP_NAME = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[0-9a-f]{8}\.tmp$")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process, or a pid too large to be one: leave the file
    return True


def write_problem(folder: Path) -> str | None:
    """Why no file can be made in ``folder`` (an existing folder), in a few words; None where
    one can. A hidden temp file of :data:`TEMP_NAME`'s form is made there and removed at once:
    the permission bits say nothing to root, and a folder of the kernel's (/proc, /sys) takes
    no file whatever its bits say."""
    tmp = folder / f".probe.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    with interrupts.deferred():   # made and removed whole, as a write is
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except OSError as error:
            return error.strerror or type(error).__name__
        os.close(fd)
        tmp.unlink(missing_ok=True)
    return None


def remove_stale_temps(folder: Path) -> int:
    """Remove the temp files of this program's runs that died in ``folder`` (SIGKILL, power
    loss): only names of :data:`TEMP_NAME`'s form whose process is gone. Returns how many."""
    removed = 0
    try:
        candidates = list(folder.glob(".*.tmp"))
    except OSError:
        return 0
    for tmp in candidates:
        match = TEMP_NAME.match(tmp.name)
        if match and tmp.is_file() and not _alive(int(match["pid"])):
            tmp.unlink(missing_ok=True)
            removed += 1
    return removed


@contextmanager
def atomic_file(path: str | Path):
    """Open a temp file beside ``path`` for binary writing; rename it over ``path`` on success
    (at the end of the :func:`together` block, inside one).

    A character device or a FIFO (``/dev/null``, a named pipe) is written to directly and never
    replaced; any other path that is not a regular file is refused with OSError.
    """
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        if not (stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)):
            raise IsADirectoryError(f"{path}: not a regular file")
        # Opened without waiting: a FIFO nobody reads would otherwise block the run for good,
        # deaf to Ctrl-C (the open is retried after each signal).
        try:
            fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as error:
            reason = "a pipe with no reader" if error.errno == errno.ENXIO else error.strerror
            raise OSError(error.errno, reason, str(path)) from None
        os.set_blocking(fd, True)
        try:
            with interrupts.deferred(), os.fdopen(fd, "wb") as f:
                yield f
        except OSError as error:
            raise OSError(error.errno, error.strerror, str(path)) from None
        return
    # The temp name is chosen before the file exists, so an interrupt that lands anywhere after
    # this line (even inside the open) still finds the name to remove. Ctrl-C itself waits for
    # the rename (game/app/interrupts.py); this covers other exceptions, and signals not deferred.
    tmp = path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    try:
        with interrupts.deferred():
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "wb") as f:
                yield f
                f.flush()
                os.fsync(f.fileno())
            os.chmod(tmp, FILE_MODE)
            if _group is not None:
                _group.append((tmp, path))
            else:
                os.replace(tmp, path)
    except OSError as error:
        Path(tmp).unlink(missing_ok=True)
        raise _write_error(path, error) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes(path: str | Path, data: bytes) -> None:
    with atomic_file(path) as f:
        f.write(data)


def write_with(path: str | Path, writer: Callable[[BinaryIO], None]) -> None:
    with atomic_file(path) as f:
        writer(f)


def write_figure(path: str | Path, figure, fmt: str = "png", dpi: int = 110) -> None:
    """A matplotlib figure, saved through the same temp-and-rename as every other file."""
    with atomic_file(path) as f:
        figure.savefig(f, format=fmt, dpi=dpi)


def png_bytes(image: np.ndarray) -> bytes:
    """Encode an (H, W, 3) or (H, W, 4) uint8 image as PNG (row 0 at the top)."""
    image = np.ascontiguousarray(image, dtype=np.uint8)
    h, w, channels = image.shape
    colour_type = {3: 2, 4: 6}[channels]
    raw = np.concatenate([np.zeros((h, 1), np.uint8), image.reshape(h, w * channels)], axis=1)

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b""))


def write_png(path: str | Path, image: np.ndarray) -> None:
    write_bytes(path, png_bytes(image))


def write_npz(path: str | Path, arrays: dict[str, np.ndarray]) -> None:
    write_with(path, lambda f: np.savez_compressed(f, **arrays))


def write_json(path: str | Path, data: dict) -> None:
    write_bytes(path, (json.dumps(data, indent=1) + "\n").encode())
