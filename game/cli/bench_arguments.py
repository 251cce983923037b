"""The ``bench`` subcommand's parser: the sweep's flags, the suites, and how the runs of a
suite are spread (local worker processes or a cluster)."""

from __future__ import annotations

import argparse
from pathlib import Path

from game.cli.values import path_value, positive_int, size_value, whole
from game.gpu.timing import CLOCKS

SUITES = ("gpu", "cache", "accuracy", "window")
MAX_SEED = 2**63 - 1
MAX_SEEDS = 100_000   # seeds in one sweep: a range past it is a typo, not a plan
MAX_WORKERS = 256


def seed_range(text: str) -> tuple[int, int]:
    """``A..B`` (both included) or one seed ``N``, as (first, last)."""
    first, sep, last = text.partition("..")
    try:
        a = int(first)
        b = int(last) if sep else a
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected A..B or N (whole numbers), got {text!r}") \
            from None
    if not (0 <= a <= MAX_SEED and 0 <= b <= MAX_SEED):
        raise argparse.ArgumentTypeError(f"seeds are 0..{MAX_SEED}, got {text!r}")
    if b < a:
        raise argparse.ArgumentTypeError(f"A..B needs A <= B, got {text!r}")
    if b - a + 1 > MAX_SEEDS:
        raise argparse.ArgumentTypeError(f"at most {MAX_SEEDS:,} seeds in one sweep, got "
                                         f"{b - a + 1:,}")
    return a, b


seed_range.__name__ = "seed range"  # argparse names the type in its messages


def add_bench_parser(sub) -> None:
    bench = sub.add_parser(
        "bench", help="speed-versus-accuracy sweeps and charts",
        description="Sweep methods x parameters x scenes along a fixed camera path; write "
                    "OUT/bench.csv (one row per run; finished rows are kept and skipped on a "
                    "rerun), OUT/charts/*.png|svg and OUT/summary.json. See docs/results.md.")
    bench.add_argument("--suite", choices=SUITES,
                       help="gpu: the checks meant for a real GPU in one command, within 8 "
                            "minutes: hard shadows on the default scene, the 1 M-triangle town "
                            "and a real level; the window's frame rate; the soft-shadow sweep "
                            "(see docs/results.md). cache: the soft tracer's CPU twin under a "
                            "cache simulator, natively and beside Embree, on the courtyard and "
                            "the monastery (OUT/cache.csv; needs numba and valgrind: "
                            "pip install -e '.[cache]'). accuracy: every map method at its "
                            "defaults on the random scenes of --seeds, scored against Embree "
                            "(OUT/accuracy.csv, accuracy.png, summary.md; see "
                            "docs/reference.md). window: the walkaround's frame rate as play "
                            "opens it, clumped beside single, with soft shadows and without, "
                            "two alternating rounds (OUT/window.csv)")
    bench.add_argument("--quick", action="store_true",
                       help="the short sweep (default scene, a small town, stability scenes), "
                            "or the GPU suite made small")
    bench.add_argument("--out", type=path_value, default=None, metavar="DIR",
                       help="output folder (default: bench, or bench_gpu, bench_cache, "
                            "bench_accuracy, bench_window for --suite gpu, cache, accuracy, "
                            "window)")
    bench.add_argument("--size", type=size_value, default=None, metavar="WxH",
                       help="frame size of every run (default: 320x180; --suite accuracy: the "
                            "size each random scene is drawn for)")
    bench.add_argument("--frames", type=positive_int, default=None,
                       help="timed frames per run (default 8, quick 4); --suite accuracy: "
                            "frames captured and scored per run (default 2)")
    bench.add_argument("--warmup", type=int, default=None,
                       help="frames before timing (default 2, quick 1)")
    bench.add_argument("--error-frames", type=int, default=None,
                       help="frames scored against Embree per run (default 2, quick 1)")
    bench.add_argument("--flicker-frames", type=int, default=None,
                       help="frames with only the camera moving, for flicker (default 3, quick 2)")
    bench.add_argument("--repeat", type=positive_int, default=1,
                       help="time each run N times, round-robin over the scene's runs, and "
                            "keep the median (steadier ratios on a loaded machine)")
    bench.add_argument("--scenes",
                       help="comma-separated built-in scene keys, patterns (town_*) or paths of "
                            "scene files (.toml); a scene file gets every method at its "
                            "defaults plus the --param values (default: the built-in sweep)")
    bench.add_argument("--methods", help="comma-separated methods (default: all map methods)")
    bench.add_argument("--param", action="append", default=[], metavar="KEY=V1,V2",
                       help="also run each value of a method parameter (clump_resolution, "
                            "single_resolution, clump_count, clumping, ...) with every method "
                            "that reads it; repeatable; replaces the built-in parameter grid")
    bench.add_argument("--list", action="store_true", help="print the runs and exit")
    bench.add_argument("--report", type=path_value, nargs="?", const=Path("."), default=None,
                       metavar="ROOT",
                       help="measure nothing: write ROOT/docs/results.md and the figure table "
                            "of ROOT/README.md from the recorded runs in ROOT/docs/runs/*/ "
                            "(ROOT: the checkout, default: this folder)")
    bench.add_argument("--no-progress", action="store_true", help="no progress bar")
    bench.add_argument("--clock", choices=CLOCKS, default="auto",
                       help="timing clock (auto: CPU around glFinish on llvmpipe, GPU queries "
                       "elsewhere; cpu-thread: the CPU time of llvmpipe's one thread, steady on "
                       "a shared machine; it sets LP_NUM_THREADS=0)")
    g = bench.add_argument_group("--suite accuracy")
    g.add_argument("--seeds", type=seed_range, default=None, metavar="A..B",
                   help="the random scenes' seeds, A to B with both included, or one seed N "
                        "(python -m game scenes random --seed N writes one)")
    g.add_argument("--workers", type=whole(1, MAX_WORKERS), default=1, metavar="N",
                   help="runs at a time, each in processes of its own with its own EGL context")
    g.add_argument("--cluster", default=None, metavar="ADDRESS",
                   help="run the runs as tasks on the Dask distributed scheduler at ADDRESS "
                        "(tcp://host:8786) instead of local processes; its workers need this "
                        "project installed and the real corpus fetched "
                        "(pip install -e '.[cluster]')")
