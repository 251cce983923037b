"""The window's soft method from the recorded rows (docs/design/raster-soft.md, "The window's
method"): ``python -m game.bench.soft_choice`` prints the soft sweep's rows on the built-in
square whose cost at the window's trace size fits within the hard frame's milliseconds at
960x540, lowest error first. Both come from recorded files, named in the output."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SOFT_ROWS = ROOT / "docs" / "images" / "soft_raster.csv"
HARD_ROWS = ROOT / "docs" / "runs" / "shading960" / "bench.csv"
HARD_RUN = "default|clumped|defaults|960x540"
SCENE = "default"
SWEEP_POINTS = 160 * 90       # the soft sweep's size
WINDOW_POINTS = 240 * 135     # the window's trace at 960x540, one pixel in 4 x 4


def budget_ms(path: Path = HARD_ROWS) -> float:
    """The hard frame's median milliseconds at 960x540 on the built-in square."""
    with path.open() as f:
        row = next(r for r in csv.DictReader(f) if r["run"] == HARD_RUN)
    return float(row["total_ms_median"])


def within(budget: float, path: Path = SOFT_ROWS) -> list[dict]:
    """The soft rows on :data:`SCENE` that fit ``budget``, lowest ``rmse_analytic`` first,
    each with its ``window_ms``: the row's frame with its per-point part scaled."""
    with path.open() as f:
        rows = [r for r in csv.DictReader(f) if r["scene"] == SCENE]
    fits = []
    for r in rows:
        frame, per_point = float(r["frame_ms"]), float(r["trace_ms"])
        cost = frame - per_point + per_point * WINDOW_POINTS / SWEEP_POINTS
        if cost <= budget:
            fits.append({"method": r["method"], "count": int(r["samples"]),
                         "rmse_analytic": float(r["rmse_analytic"]), "window_ms": cost})
    return sorted(fits, key=lambda x: x["rmse_analytic"])


def main() -> int:
    budget = budget_ms()
    print(f"budget: {budget:.1f} ms ({HARD_ROWS.relative_to(ROOT)}, {HARD_RUN})")
    print(f"rows of {SOFT_ROWS.relative_to(ROOT)} on {SCENE} within it, lowest error first:")
    for row in within(budget):
        print(f"  {row['method']} {row['count']}: rmse_analytic {row['rmse_analytic']:.4f}, "
              f"{row['window_ms']:.1f} ms at the window's points")
    return 0


if __name__ == "__main__":
    sys.exit(main())
