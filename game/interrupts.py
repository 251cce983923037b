"""Ctrl-C that no library can swallow.

trimesh catches ``BaseException`` in places (hashing in its caches, optional imports), so a
KeyboardInterrupt raised while it runs can be lost: a ``capture --dump`` then went on rendering
after Ctrl-C (tests/test_safe_outputs.py hung in 2 runs out of 15). The handler installed here
raises KeyboardInterrupt as Python's own does, and also remembers the signal; the long loops
(frames, bench runs) call :func:`check` at every step, which raises again if it was swallowed.
"""

from __future__ import annotations

import signal
import threading

_pending = False


def _on_sigint(signum, frame) -> None:
    global _pending
    _pending = True
    raise KeyboardInterrupt


def install() -> None:
    """Take over SIGINT where Python's default handler has it (not where it is ignored, as in
    background jobs of a shell, and only from the main thread, where handlers can be set)."""
    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        signal.signal(signal.SIGINT, _on_sigint)


def check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C came since :func:`install`, even if it was swallowed."""
    if _pending:
        raise KeyboardInterrupt
