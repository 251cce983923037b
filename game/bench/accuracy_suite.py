"""``python -m game bench --suite accuracy --seeds A..B``: does the accuracy hold on scenes
nobody tuned for?

For every seed the suite draws a random scene (game/scene/random_scene.py) and runs every map
method of the registry at its defaults on it, each run captured with dumps and scored against
Embree exactly as ``python -m game verify`` scores it (game/bench/accuracy_tasks.py). The runs
are independent: they go to local worker processes (``--workers N``) or to a Dask cluster
(``--cluster ADDRESS``, game/bench/accuracy_pool.py), and come back as CSV rows and files.

It writes into OUT:

- ``accuracy.csv``: one row per seed x method (rewritten whole after every run; a rerun into the
  same folder keeps the finished rows of the same scenes and makes only the others);
- ``accuracy.png``: the error's distribution per method, and clumped against the better
  baseline, seed by seed (game/bench/accuracy_chart.py);
- ``summary.md`` and ``summary.json``: the targets' counts and the worst seeds
  (game/bench/accuracy_summary.py); ``run.json``: the command, the renderer, the date;
- ``scenes/random_N.toml``: each scene's text (``python -m game scenes random --seed N`` writes
  its whole folder, meshes included), and ``runs/N/METHOD/``: each run's stats, scores, first
  frame and error pictures.
"""

from __future__ import annotations

import csv
import os
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from game.app import outputs
from game.bench import accuracy_chart, accuracy_pool, accuracy_summary
from game.bench.accuracy_tasks import AccuracyTask, scene_hash
from game.bench.rows import write_table
from game.bench.runner import git_commit
from game.data import CHECKOUT_DIR
from game.errors import GameError
from game.scene import random_scene
from game.shadows import registry

DEFAULT_FRAMES = 2
FIELDS = ("seed", "method", "width", "height", "frames", "lights", "characters",
          "static_triangles", "misclassified", "shadowed", "shadowed_either", "considered",
          "error_pct", "worst_light_error_pct", "light_misclassified", "ms", "first_ms",
          "notes", "status", "seconds", "scene", "scene_sha256", "renderer", "worker")
OUTPUT_FILES = ("accuracy.csv", "accuracy.png", "summary.md", "summary.json", "run.json")


@dataclass
class AccuracySuite:
    out: Path
    seeds: tuple[int, int]                 # first and last, both included
    size: tuple[int, int] | None = None    # None: the size each scene is drawn for
    frames: int = DEFAULT_FRAMES
    workers: int = 1
    cluster: str | None = None             # a Dask scheduler's address
    methods: tuple[str, ...] = registry.MAP_METHODS
    log: Callable[[str], None] = print
    notes: list[str] = field(default_factory=list)


def check_outputs(out: Path) -> None:
    """Refuse at once, before any run, an output in the way."""
    outputs.check_paths(files=[out / name for name in OUTPUT_FILES],
                        folders=[out, out / "scenes", out / "runs"])


def plan(suite: AccuracySuite) -> tuple[list[AccuracyTask], dict[int, random_scene.RandomScene]]:
    """Every seed's scene, and a task per seed x method."""
    first, last = suite.seeds
    scenes = {seed: random_scene.draw(seed) for seed in range(first, last + 1)}
    tasks = [AccuracyTask(seed, method, suite.size or scene.size, suite.frames,
                          scene_hash(scene.text))
             for seed, scene in scenes.items() for method in suite.methods]
    return tasks, scenes


def read_rows(path: Path) -> list[dict]:
    """The rows of an earlier sweep into the same folder (none where there is no file)."""
    if not path.exists():
        return []
    try:
        with path.open(newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            if tuple(reader.fieldnames or ()) != FIELDS:
                raise GameError(f"{path}: not an accuracy CSV (its header is not the suite's "
                                "columns); move it away or choose another --out")
            return [row for row in reader if None not in row.values()]
    except (UnicodeDecodeError, csv.Error) as error:
        raise GameError(f"{path}: not an accuracy CSV ({error})") from None


def run_key(row: dict) -> str:
    return f"{row['seed']}|{row['method']}|{row['width']}x{row['height']}|{row['frames']}"


def run(suite: AccuracySuite, command: str = "") -> dict:
    """The sweep; returns its summary with ``csv``, ``wall_s`` and ``failed`` added."""
    check_outputs(suite.out)
    if suite.cluster is not None:
        accuracy_pool.connect(suite.cluster).close()  # no scheduler: one line, before any work
    tasks, scenes = plan(suite)
    (suite.out / "scenes").mkdir(parents=True, exist_ok=True)
    for scene in scenes.values():
        outputs.write_bytes(suite.out / "scenes" / scene.file_name, scene.text.encode())
    csv_path = suite.out / "accuracy.csv"
    planned = {t.run_id: t for t in tasks}

    def current(row: dict) -> bool:
        """Kept: a finished run of this sweep's scene, or a row of other seeds or sizes."""
        task = planned.get(run_key(row))
        return task is None or (row.get("status") == "ok"
                                and row["scene_sha256"] == task.scene_sha256)

    rows = [r for r in read_rows(csv_path) if current(r)]
    done = {run_key(r) for r in rows}
    todo = [t for t in tasks if t.run_id not in done]
    where = (f"the Dask cluster at {suite.cluster}" if suite.cluster
             else f"{suite.workers} local worker{'s' if suite.workers > 1 else ''}")
    suite.log(f"accuracy: {len(tasks)} runs on {len(scenes)} scenes, "
              f"{len(tasks) - len(todo)} already in "
              f"{csv_path}, {len(todo)} to go, on {where}")
    start = time.perf_counter()
    results = (accuracy_pool.cluster_results(todo, suite.cluster) if suite.cluster
               else accuracy_pool.local_results(todo, suite.workers))
    for k, result in enumerate(results, 1):
        row = result["row"]
        rows = [r for r in rows if run_key(r) != run_key(row)] + [row]
        write_table(csv_path, _ordered(rows, suite.methods), list(FIELDS))
        folder = suite.out / "runs" / str(row["seed"]) / row["method"]
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in result["files"].items():
            outputs.write_bytes(folder / name, data)
        suite.log(f"[{k}/{len(todo)}] {_said(row)}")
    wall = round(time.perf_counter() - start, 1)
    rows = [r for r in rows if run_key(r) in planned]  # the summary is of this sweep's runs
    summary = accuracy_summary.summarise(rows, suite.methods)
    summary.update(seeds=list(suite.seeds), wall_s=wall, workers=suite.workers,
                   cluster=suite.cluster)
    outputs.write_json(suite.out / "summary.json", accuracy_summary.json_ready(summary))
    outputs.write_bytes(suite.out / "summary.md",
                        accuracy_summary.markdown(summary, command).encode())
    accuracy_chart.write_chart(suite.out / "accuracy.png", rows, suite.methods, summary)
    _write_record(suite, command, rows, wall, summary["run_seconds"])
    failed = [f"{r['seed']} {r['method']}: {r['status']}" for r in rows
              if str(r.get("status", "")).startswith("failed")]
    return {**summary, "csv": str(csv_path), "failed": failed}


def _ordered(rows: list[dict], methods) -> list[dict]:
    order = {m: i for i, m in enumerate(methods)}
    return sorted(rows, key=lambda r: (int(r["seed"]), order.get(r["method"], len(order))))


def _said(row: dict) -> str:
    head = f"seed {row['seed']} {row['method']}"
    if row.get("status") != "ok":
        return f"{head}: {row.get('status')}"
    return (f"{head}: error {float(row['error_pct']):.2f}% ({row['misclassified']} of "
            f"{row['shadowed_either']} pixels), {float(row['ms']):.1f} ms a frame, "
            f"{float(row['seconds']):.0f} s")


def _write_record(suite: AccuracySuite, command: str, rows: list[dict], wall: float,
                  run_seconds: float) -> None:
    """``OUT/run.json``: what a reader of the figures needs to make them again. ``wall_s`` is
    this command's; ``run_seconds`` the runs' own, summed (a resumed sweep's too)."""
    renderers = sorted({r["renderer"] for r in rows if r.get("renderer")})
    record = {"command": command, "renderer": "; ".join(renderers),
              "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
              "seeds": list(suite.seeds), "frames": suite.frames,
              "size": "each scene's own" if suite.size is None else list(suite.size),
              "workers": suite.workers, "cluster": suite.cluster, "wall_s": wall,
              "run_seconds": run_seconds,
              "machine": {"platform": platform.platform(), "cores": os.cpu_count()},
              **git_commit(CHECKOUT_DIR)}
    outputs.write_json(suite.out / "run.json", record)
