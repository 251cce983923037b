"""The accuracy sweep's chart (``OUT/accuracy.png``).

Left: each method's error on every scene, one dot per seed over a box of its quartiles, on a
scale that is linear near zero and logarithmic above 1% (most scenes are near zero, a few are
far off). Right: seed by seed, clumped's misclassified pixels against the better baseline's,
with the target's bound and its ceiling: a dot above a line breaks it.
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from pathlib import Path

from game.app import outputs
from game.bench.accuracy_summary import (
    CEILING_RATIO,
    CEILING_SLACK_PX,
    MAX_ERROR_PCT,
    TARGET_RATIO,
    TARGET_SLACK_PX,
    by_seed,
    comparisons,
)
from game.bench.chart_axes import pyplot
from game.bench.charts import COLOURS
from game.bench.rows import row_number

JITTER = 0.18     # half the width of a method's column of dots
JITTER_SEED = 0   # the dots' spread is the same on every run of the same rows
ERROR_TICKS = (0, 0.25, 0.5, 1, 2, 5, 10, 20, 50, 100)   # percent
VERDICTS = (("within the target", "#2ca02c"), ("over the target", "#ff7f0e"),
            ("over the ceiling", "#d62728"))


def write_chart(path: Path, rows: Sequence[dict], methods: Sequence[str], summary: dict) -> None:
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5.2))
    _distribution(left, rows, methods)
    _against(right, rows, summary)
    fig.suptitle(f"{summary['scenes']} random scenes, every method at its defaults, against "
                 "Embree", fontsize=10)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


def _distribution(ax, rows: Sequence[dict], methods: Sequence[str]) -> None:
    jitter = random.Random(JITTER_SEED)
    seeds = by_seed(rows)
    data = []
    for i, method in enumerate(methods):
        errors = [row_number(runs[method], "error_pct") for runs in seeds.values()
                  if method in runs]
        data.append(errors or [float("nan")])
        xs = [i + jitter.uniform(-JITTER, JITTER) for _ in errors]
        ax.scatter(xs, errors, s=9, alpha=0.6, color=COLOURS.get(method, "grey"), zorder=3)
    ax.boxplot(data, positions=range(len(methods)), widths=0.6, showfliers=False,
               medianprops={"color": "black"}, zorder=2)
    ax.axhline(MAX_ERROR_PCT, color="black", linestyle="--", linewidth=0.8)
    ax.set_yscale("symlog", linthresh=1.0, linscale=1.5)
    top = max([e for errors in data for e in errors if e == e] + [MAX_ERROR_PCT])
    ticks = [t for t in ERROR_TICKS if t <= top * 1.5]
    ax.set_ylim(0, top * 1.3)
    ax.set_yticks(ticks, [f"{t:g}%" for t in ticks])
    ax.minorticks_off()
    ax.set_xticks(range(len(methods)), methods)
    ax.set_ylabel("shadow error vs Embree, % of pixels shadowed by either")
    ax.set_title("error per scene (frames and lights pooled)", fontsize=9)
    ax.grid(True, axis="y", which="both", alpha=0.3)


def _against(ax, rows: Sequence[dict], summary: dict) -> None:
    pairs = comparisons(rows)
    if not pairs:
        ax.text(0.5, 0.5, "no scene where clumped and both baselines finished",
                ha="center", transform=ax.transAxes)
        return
    best = [p["baseline_misclassified"] for p in pairs]
    mine = [p["clumped"] for p in pairs]
    verdict = [0 if p["within"] else 1 if p["under_ceiling"] else 2 for p in pairs]
    for k, (label, colour) in enumerate(VERDICTS):
        shown = [(b + 1, m + 1) for b, m, v in zip(best, mine, verdict, strict=True) if v == k]
        if shown:
            xs, ys = zip(*shown, strict=True)
            ax.scatter(xs, ys, s=14, color=colour, zorder=3,
                       label=f"{label}: {len(shown)} scene{'s' if len(shown) > 1 else ''}")
    top = max(max(best), max(mine)) + 1
    xs = [1 + k * top / 200 for k in range(201)]
    ax.plot(xs, [TARGET_RATIO * (x - 1) + TARGET_SLACK_PX + 1 for x in xs], "k-", lw=0.9,
            label=f"target: {TARGET_RATIO:g}x + {TARGET_SLACK_PX:g} px")
    ax.plot(xs, [CEILING_RATIO * (x - 1) + CEILING_SLACK_PX + 1 for x in xs], "k--", lw=0.9,
            label=f"ceiling: {CEILING_RATIO:g}x + {CEILING_SLACK_PX:g} px")
    ax.plot(xs, xs, color="grey", lw=0.6, label="equal")
    for p in summary["worst_against_baseline"]:
        if not p["within"]:
            ax.annotate(str(p["seed"]), (p["baseline_misclassified"] + 1, p["clumped"] + 1),
                        fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("misclassified pixels + 1, the better of single and static-dynamic")
    ax.set_ylabel("misclassified pixels + 1, clumped")
    ax.set_title(f"clumped against the better baseline, seed by seed: within the target on "
                 f"{summary['within_target']} of {summary['compared']}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
