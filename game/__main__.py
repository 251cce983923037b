"""``python -m game``: see game/cli/."""

import signal
import sys


def _stopped_while_loading(signum, frame):
    """SIGTERM or SIGHUP before game/app/interrupts.py takes over: the same line and status."""
    print(f"terminated by {signal.Signals(signum).name}", file=sys.stderr)
    sys.exit(128 + signum)


_stopped_while_loading.replaceable = True  # game/app/interrupts.py installs its own over it
for _stop in (signal.SIGTERM, signal.SIGHUP):
    if signal.getsignal(_stop) is signal.SIG_DFL:
        signal.signal(_stop, _stopped_while_loading)

try:
    from game.cli import main
except KeyboardInterrupt:  # Ctrl-C while the modules load, before game/app/interrupts.py is set
    print("interrupted", file=sys.stderr)
    sys.exit(130)

status = main()
# The run is over: a signal now must not kill the program on its way out (Python gives SIGINT
# back its default action while it shuts down), so that it exits with the run's status.
for stop in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    signal.signal(stop, signal.SIG_IGN)
sys.exit(status)
