"""Ctrl-C that always ends a run the same way: exit 130, one line, every file whole.

Python raises KeyboardInterrupt wherever the main thread happens to be, and three places turned
that into something else (seen in 150 captures stopped at random moments):
- trimesh catches ``BaseException`` in places (hashing in its caches), so the interrupt was lost
  and ``capture --dump`` went on rendering;
- inside a ctypes call PyOpenGL makes, it came back as ``ctypes.ArgumentError``;
- inside ``numpy.savez``, zipfile's cleanup raised ValueError over it and left a traceback.
So the handler here also remembers the signal (:func:`pending`, for the command line's last
``except``), the long loops call :func:`check` at every step, and :func:`deferred` holds the
interrupt while a file is written (game/app/outputs.py), raising it once the file is in place.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

_pending = False
_deferring = 0


def _on_sigint(signum, frame) -> None:
    global _pending
    _pending = True
    if not _deferring:
        raise KeyboardInterrupt


def install() -> None:
    """Take over SIGINT where Python's default handler has it (not where it is ignored, as in
    background jobs of a shell, and only from the main thread, where handlers can be set)."""
    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        signal.signal(signal.SIGINT, _on_sigint)


def pending() -> bool:
    """Whether Ctrl-C came since :func:`install`."""
    return _pending


def check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C came, even if something swallowed it since."""
    if _pending and not _deferring:
        raise KeyboardInterrupt


@contextmanager
def deferred() -> Iterator[None]:
    """Hold Ctrl-C inside the block; raise it when the block has finished."""
    global _deferring
    _deferring += 1
    try:
        yield
    finally:
        _deferring -= 1
    check()


@dataclass
class Caught:
    happened: bool = False


@contextmanager
def caught() -> Iterator[Caught]:
    """End the block at Ctrl-C instead of unwinding further; ``.happened`` says whether it did.

    For runs that still have work to do after an interrupt (the stats of the finished frames);
    they raise KeyboardInterrupt again themselves once that is done.
    """
    result = Caught()
    try:
        yield result
    except KeyboardInterrupt:
        result.happened = True
