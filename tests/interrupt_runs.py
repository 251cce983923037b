"""Interrupt real runs at random moments and count how each ended (not a test: a tool).

    python tests/interrupt_runs.py bench|soft RUNS [SEED]

Each run starts ``python -m game`` (a one-scene bench, or a small ``capture --dump --soft``),
sleeps 0.3 to 4 s, sends SIGINT, and records the exit status: 0 (finished first) and 130
(interrupted) are clean; anything else is printed with the end of its standard error.
"""

import collections
import os
import random
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COMMANDS = {
    "bench": ["bench", "--quick", "--scenes", "default", "--methods", "clumped", "--no-progress",
              "--out", "{out}"],
    "soft": ["capture", str(ROOT / "tests/scenes/tiny.toml"), "--dump", "--soft", "--size",
             "64x36", "--frames", "3", "--out", "{out}"],
}


def main() -> None:
    which, runs = sys.argv[1], int(sys.argv[2])
    random.seed(int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    endings = collections.Counter()
    env = {**os.environ, "PYTHONFAULTHANDLER": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(runs):
            args = [a.format(out=f"{tmp}/{i}") for a in COMMANDS[which]]
            proc = subprocess.Popen([sys.executable, "-m", "game", *args], cwd=ROOT, env=env,
                                    preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
                                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    text=True)
            try:
                proc.wait(timeout=random.uniform(0.3, 4.0))
            except subprocess.TimeoutExpired:
                proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=300)
            endings[proc.returncode] += 1
            if proc.returncode not in (0, 130):
                print(f"run {i}: exit {proc.returncode}\n{err[-1500:]}")
    print(f"{which}: {runs} runs, exit status: count {dict(endings)}")


if __name__ == "__main__":
    main()
