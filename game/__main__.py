"""``python -m game``: see game/cli/."""

import signal
import sys


def _received_while_loading(signum, frame):
    """Ctrl-C, SIGTERM or SIGHUP before game/app/interrupts.py takes over: only recorded. Raised
    in the middle of an import, an exception leaves modules half made (trimesh's imports catch it
    and fail later), so the run ends cleanly once the modules are in."""
    _received_while_loading.received.append(signum)


_received_while_loading.received = []
_received_while_loading.replaceable = True  # game/app/interrupts.py installs its own over it
for _stop in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    if signal.getsignal(_stop) in (signal.SIG_DFL, signal.default_int_handler):
        signal.signal(_stop, _received_while_loading)

from game.cli import main  # noqa: E402 - after the handlers, so that no signal lands inside it

status = main()
# The run is over: a signal now must not kill the program on its way out (Python gives SIGINT
# back its default action while it shuts down), so that it exits with the run's status.
for stop in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    signal.signal(stop, signal.SIG_IGN)
sys.exit(status)
