"""``python -m game bench --suite window``: the walkaround's frame rate, as ``play`` opens it.

The built-in scene at 960x540 on GLFW's null platform, with the overlay, FXAA and PCF on (the
window's defaults), its walkers walking:

- ``clumped`` and ``single`` with the camera still: what the multi-map method is worth in the
  window;
- the window's method with soft shadows and without, the camera still and turning by a degree a
  frame, back and forth within 30 degrees of its first view: what the linear light costs.

Each run is one process (one window, one GL context; game/bench/soft_window.py ``fps``), timed
by that process's CPU time after a warm-up. With ``LP_NUM_THREADS=0`` (set here for every run)
llvmpipe rasterises in the calling thread, so other processes' load does not count; a GPU
ignores it. The runs take turns, in the opposite order in each round. It writes
``OUT/window.csv`` and ``OUT/run.json``; the results page shows them (game/bench/report_window.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from game.bench.rows import write_table
from game.bench.runner import write_run_record
from game.errors import GameError

# (method, soft, degrees the camera turns a frame); method None: the window's own.
RUNS = (("clumped", False, 0.0), ("single", False, 0.0), (None, False, 1.0),
        (None, True, 0.0), (None, True, 1.0))
ROUNDS, QUICK_ROUNDS = 2, 1
FRAMES, QUICK_FRAMES = 300, 3
COLUMNS = ["round", "order", "method", "soft", "soft_method", "turn_degrees", "sweep_degrees",
           "pcf", "as_shown", "width", "height", "frames", "fps_cpu", "fps_wall", "ms_cpu",
           "shade_ms", "renderer", "version"]
RUN_TIMEOUT_S = 900


@dataclass(frozen=True)
class WindowSuite:
    out: Path
    frames: int = FRAMES
    rounds: int = ROUNDS


def run_suite(suite: WindowSuite, command: str, say=print) -> Path:
    """Every run of every round, in turns; returns the CSV written. The output folder is made
    first, so that a path that cannot be made fails before the runs, and what was made for it
    is removed again if the suite fails."""
    made = _make_folder(suite.out)
    try:
        rows = []
        for round_ in range(1, suite.rounds + 1):
            order = RUNS if round_ % 2 else tuple(reversed(RUNS))
            for k, (method, soft, turn) in enumerate(order):
                row = _one(method, soft, turn, suite.frames)
                rows.append({"round": round_, "order": k, **row})
                say(f"round {round_}: {row['method']}{' soft' if soft else ''}"
                    f"{f' turning {turn:g} deg/frame' if turn else ''}: "
                    f"{row['fps_cpu']:.2f} fps")
        path = suite.out / "window.csv"
        write_table(path, rows, COLUMNS)
        write_run_record(suite.out, command, {"renderer": rows[0]["renderer"],
                                              "version": rows[0]["version"]}, clock="cpu-process")
    except BaseException:
        _remove_empty(made)
        raise
    return path


def _make_folder(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; returns those made, deepest first. A folder
    that cannot be made leaves none of them behind."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        _remove_empty(missing)
        raise
    return missing


def _remove_empty(folders: list[Path]) -> None:
    """Remove each of ``folders`` (deepest first) that exists and is empty."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            pass


def _one(method: str | None, soft: bool, turn: float, frames: int) -> dict:
    """One run in its own process: its JSON line."""
    argv = [sys.executable, "-m", "game.bench.soft_window", "fps", "--as-shown",
            "--frames", str(frames), "--turn", str(turn)]
    argv += ["--method", method] if method else []
    argv += ["--soft"] if soft else []
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
                              env={**os.environ, "LP_NUM_THREADS": "0"})
    except subprocess.TimeoutExpired:
        raise GameError(f"window suite: a run took over {RUN_TIMEOUT_S} s: "
                        f"{' '.join(argv[1:])}") from None
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        why = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise GameError(f"window suite: {' '.join(argv[1:])} failed: {why}")
    return json.loads(lines[-1])
