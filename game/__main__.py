"""``python -m game``: see game/cli/."""

import signal
import sys

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
