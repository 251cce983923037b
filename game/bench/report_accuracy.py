"""The results page's section on random scenes, from a recorded accuracy sweep.

An accuracy run (``python -m game bench --suite accuracy --seeds A..B --out docs/runs/NAME``)
holds ``accuracy.csv``: per seed and map method, the misclassified pixels against Embree and
the error. Everything said here is computed from that file (game/bench/accuracy_summary.py).
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

from game.bench.accuracy_summary import BASELINES, summarise
from game.bench.suite_records import SuiteRun, read_suite_run

ACCURACY_COLUMNS = ("seed", "method", "misclassified", "shadowed_either", "error_pct", "notes",
                    "status")


def is_accuracy_run(folder: Path) -> bool:
    return (folder / "accuracy.csv").is_file()


def load_accuracy_run(folder: Path) -> SuiteRun:
    """An accuracy sweep's folder; a missing or garbled file is refused in one line."""
    run = read_suite_run(folder, "accuracy.csv", ACCURACY_COLUMNS, "accuracy sweep", "accuracy")
    return dataclasses.replace(run, rows=_recorded(run.rows, run.record))


def _recorded(rows: list[dict], record: dict) -> list[dict]:
    """The rows of the sweep the record describes: a CSV also keeps the rows of earlier,
    longer sweeps into the same folder."""
    seeds = record.get("seeds")
    if not (isinstance(seeds, list) and len(seeds) == 2):
        return rows
    first, last = seeds
    return [r for r in rows if r["seed"].isdigit() and first <= int(r["seed"]) <= last]


def _pct(value: float | None) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.2f}%"


def accuracy_section(run: SuiteRun, here: Path) -> list[str]:
    """The section of the results page: the targets' counts first, then the figures per
    method and the worst seeds."""
    methods = tuple(dict.fromkeys(r["method"] for r in run.rows))
    s = summarise(run.rows, methods)
    t = s["targets"]
    rec = run.record
    where = Path(os.path.relpath(run.folder, here)).as_posix()
    size = rec.get("size")
    at = (f"at {size[0]}x{size[1]}" if isinstance(size, list) and len(size) == 2
          else "at each scene's own size")
    lines = [
        f"## Accuracy on random scenes, {at}", "",
        "Every map method at its defaults on seeded random scenes (`python -m game scenes "
        "random --seed N`: crowds of capsules and real meshes, statics of every shape, real "
        "props, the real level, suns, spot and point lamps, street-level and high cameras), "
        f"each run scored against Embree as `verify` scores it, {at}.", "",
        f"**What the figures say.** On {s['compared']} scenes `clumped` misclassifies at most "
        f"{t['ratio']:g}x the pixels of the better of {' and '.join(f'`{b}`' for b in BASELINES)}"
        f" plus {t['slack_px']:g} on {s['within_target']} "
        f"({_pct(100 * s['within_share'])}; the target is {100 * t['share']:g}%), and more "
        f"than {t['ceiling_ratio']:g}x plus {t['ceiling_slack_px']:g} on {s['over_ceiling']}.",
        "",
        f"Run [`{run.name}`]({where}/run.json): `{rec['command']}`; "
        f"{rec.get('renderer', '')}; {rec['date']}.", "",
        f"![error per method and clumped against the better baseline]({where}/accuracy.png)", "",
        f"A run is counted over {t['max_error_pct']:g}% only where it misclassifies more "
        f"than {t['tiny_run_px']:g} pixels: where every shadow is a few pixels across, one "
        "pixel is several per cent of them.", "",
        "| method | scenes | median error | 95th percentile | largest | over "
        f"{t['max_error_pct']:g}% (more than {t['tiny_run_px']:g} px) | "
        "of them without a note |",
        "|---|---|---|---|---|---|---|"]
    for f in s["methods"]:
        lines.append(f"| `{f['method']}` | {f['runs']} | {_pct(f['median_error_pct'])} | "
                     f"{_pct(f['p95_error_pct'])} | {_pct(f['max_error_pct'])} | "
                     f"{f['over_max']} | {f['over_max_without_note']} |")
    lines += ["", "The seeds where `clumped` is furthest above the target (misclassified "
              "pixels, the frames and lights pooled):", "",
              "| seed | clumped | the better baseline | target | scene |",
              "|---|---|---|---|---|"]
    for p in s["worst_against_baseline"]:
        lines.append(f"| {p['seed']} | {p['clumped']} | `{p['baseline']}`: "
                     f"{p['baseline_misclassified']} | {p['bound']:.0f} | {p['scene']} |")
    lines.append("")
    return lines
