"""Ctrl-C (and SIGTERM, SIGHUP) that always end a run the same way: one line, exit 128 + the
signal's number (130 for Ctrl-C), every file whole, no temp file left.

Python raises KeyboardInterrupt wherever the main thread happens to be, and three places turned
that into something else (seen in 150 captures stopped at random moments):
- trimesh catches ``BaseException`` in places (hashing in its caches), so the interrupt was lost
  and ``capture --dump`` went on rendering;
- inside a ctypes call PyOpenGL makes, it came back as ``ctypes.ArgumentError``;
- inside ``numpy.savez``, zipfile's cleanup raised ValueError over it and left a traceback.
So the handler here also remembers the signal (:func:`pending`, for the command line's last
``except``), the long loops call :func:`check` at every step, and :func:`deferred` holds the
interrupt while a file is written (game/app/outputs.py), raising it once the file is in place.
SIGTERM and SIGHUP take the same path, as KeyboardInterrupt: a run stopped by ``kill`` or a
closed terminal cleans up exactly as one stopped with Ctrl-C. While the main thread is inside a
GL library, or while a module is being imported, the interrupt is never raised (see
:func:`_unsafe`), only recorded. Once one is raised the run is unwinding, and a further signal is
only recorded too: raised in the clean-up, it cut the stats' write short.

The exception raised is :class:`Interrupted`, a KeyboardInterrupt of its own type: CPython
remembers a plain KeyboardInterrupt that escaped code run by ``exec`` of a string (dataclasses
and namedtuples build their methods so) even once it is caught, and at exit kills its own process
with SIGINT instead of returning the run's status (130 became -2, one run in twenty stopped at
start-up). It marks only the exact type.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import NoReturn

_pending = False
_signal = signal.SIGINT   # the signal that stopped the run
_deferring = 0
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


_finished = False
_raised = False   # an Interrupted has been raised: the run is unwinding
# Libraries whose C code calls back into Python (moderngl builds its uniform and attribute
# objects that way; PyOpenGL and glfw go through ctypes; imgui through its bindings). An
# exception raised in such a callback is not checked by the C code around it: Ctrl-C raised
# there crashed the process (SIGSEGV inside program and compute-shader creation). Inside them
# the interrupt is only recorded, and raised at the next :func:`check`.
_GL_PACKAGES = ("moderngl", "glcontext", "OpenGL", "glfw", "imgui_bundle")


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, SIGTERM or SIGHUP, raised by this module (see the module's docstring for why a
    type of its own)."""


def _unsafe(frame) -> bool:
    """Whether the main thread is inside a GL library, or inside an import: an exception there
    leaves a module half made (trimesh's imports catch it and fail later with a TypeError)."""
    while frame is not None:
        name = frame.f_code.co_filename
        if name.startswith("<frozen importlib"):
            return True
        parts = name.replace("\\", "/").split("/")
        if any(package in parts for package in _GL_PACKAGES):
            return True
        frame = frame.f_back
    return False


def _on_signal(signum, frame) -> None:
    global _pending, _signal
    if _finished:  # the run is over and exits with its own status
        return
    _pending = True
    _signal = signal.Signals(signum)
    # Once one is raised, the run is unwinding (its stats being written, its last line): a
    # second one raised there would cut that short and escape as a traceback.
    if not _raised and not _deferring and not _unsafe(frame):
        _raise()


def _raise() -> NoReturn:
    global _raised
    _raised = True
    raise Interrupted


def install() -> None:
    """Take over SIGINT where Python's default handler has it, and SIGTERM and SIGHUP where
    they are at their defaults (not where they are ignored, as for background jobs or under
    nohup; and only from the main thread, where handlers can be set)."""
    global _finished, _pending, _signal, _deferring, _raised
    if threading.current_thread() is not threading.main_thread():
        return
    # A new run: nothing of an earlier one in this process is pending.
    _finished, _pending, _signal, _deferring, _raised = False, False, signal.SIGINT, 0, False
    for sig in (signal.SIGINT, *STOP_SIGNALS):
        current = signal.getsignal(sig)
        default = signal.default_int_handler if sig == signal.SIGINT else signal.SIG_DFL
        if current is default or getattr(current, "replaceable", False):
            signal.signal(sig, _on_signal)
        # A signal that came while the program loaded (game/__main__.py records it): the first
        # check raises it.
        if getattr(current, "received", None) and not _pending:
            _pending, _signal = True, signal.Signals(current.received[0])


def finish() -> None:
    """The run is over: a signal that comes now is ignored, so that the program exits with the
    run's own status (not killed by the signal on its way out)."""
    global _finished
    _finished = True


def stopped_by() -> tuple[str, int]:
    """The line to print and the exit status for the signal that stopped the run."""
    if _signal == signal.SIGINT:
        return "interrupted", 130
    return f"terminated by {_signal.name}", 128 + int(_signal)


def pending() -> bool:
    """Whether Ctrl-C (or SIGTERM, SIGHUP) came since :func:`install`."""
    return _pending


def check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C came, even if something swallowed it since."""
    if _pending and not _deferring:
        _raise()


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
