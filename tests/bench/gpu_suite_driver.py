"""Runs ``python -m game bench --suite gpu --quick ARGS`` with its quick plan made smaller and a
small scene as the real level, for tests/bench/test_gpu_suite.py: every part, every file and
every code path of the suite, in a fraction of the time. Not a test module.

Runs in its own process: the window part opens a window, whose GL context must not meet the test
session's headless one.
"""

from __future__ import annotations

import dataclasses
import functools
import sys

from game import cli
from game.bench import gpu_suite
from tests.helpers import TINY

# The quick plan's parts with fewer frames and samples, and the courtyard beside the real
# level but no town: a bench run costs about its scene's load, maps and reference, whatever it
# times, and a scene made from text, as the town is, takes a path through the bench that
# tests/bench/test_bench.py runs (its stability scene).
SMALL = dataclasses.replace(gpu_suite.QUICK, towns=(), frames=1, warmup=0, window_frames=6,
                            soft_samples=(1, 8))
REAL_LEVEL = TINY   # stands in for the fetched level: the same user-scene path, in seconds


def main(args: list[str]) -> int:
    gpu_suite.QUICK = SMALL
    gpu_suite.Suite = functools.partial(gpu_suite.Suite, real_level=REAL_LEVEL)
    return cli.main(["bench", "--suite", "gpu", "--quick", *args])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
