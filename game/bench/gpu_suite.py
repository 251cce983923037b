"""``python -m game bench --suite gpu``: the checks meant for a machine with a real GPU, in one
command that keeps to a time budget.

A machine with a GPU may be lent for a few minutes only, so the suite runs what the project's
figures rest on, in this order, and starts no new work once its budget is spent:

1. ``hard``: clumped against every baseline (game/bench/acceptance.py) on the courtyard, the
   1 M-triangle town and, once fetched (``python assets/fetch_real.py``), a real level;
2. ``window``: the walkaround's frame rate on GLFW's null platform, overlay on;
3. ``soft``: the soft-shadow sweep at N = 1..64, Embree on the same rays beside it.

Every part records the GL_RENDERER and the clock that timed it. The clock is ``auto``: GPU timer
queries where the driver is not a software rasteriser, the CPU around glFinish where it is
(game/gpu/timing.py). ``--quick`` runs the same parts small, in about a minute on llvmpipe.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from game.app import outputs
from game.bench import runner, runs, soft_sweep
from game.bench.rows import write_table
from game.gpu import context
from game.scene import default_scene_path, load_scene, reference_scene_path

BUDGET_S = 480.0     # the whole suite: 8 minutes
# A real level, where assets/fetch_real.py has fetched it (it is not part of the wheel).
REAL_LEVEL = default_scene_path().parent / "real" / "monastery.toml"


@dataclass(frozen=True)
class SuitePlan:
    """How big each part is."""

    size: tuple[int, int]                 # hard shadows: frame size
    towns: tuple[str, ...]                # bench scene keys beside the courtyard
    single_resolutions: tuple[int, ...]   # extra runs of single and static-dynamic
    frames: int
    warmup: int
    error_frames: int
    window_size: tuple[int, int]
    window_frames: int
    soft_size: tuple[int, int]
    soft_samples: tuple[int, ...]
    quick: bool = False


FULL = SuitePlan(size=(960, 540), towns=("town_8x8",), single_resolutions=(8192,), frames=8,
                 warmup=2, error_frames=1, window_size=(960, 540), window_frames=300,
                 soft_size=(160, 90), soft_samples=(1, 2, 4, 8, 16, 32, 64))
QUICK = SuitePlan(size=(160, 90), towns=("town_2x2",), single_resolutions=(2048,), frames=2,
                  warmup=1, error_frames=1, window_size=(320, 180), window_frames=20,
                  soft_size=(48, 27), soft_samples=(1, 8, 64), quick=True)


@dataclass
class Suite:
    out: Path
    quick: bool = False
    budget_s: float = BUDGET_S
    progress: bool = True
    real_level: Path | None = REAL_LEVEL
    log: Callable[[str], None] = field(default=lambda line: print(line, file=sys.stderr))

    @property
    def plan(self) -> SuitePlan:
        return QUICK if self.quick else FULL


def run(suite: Suite) -> dict:
    """Run the parts in order within the budget; write OUT/summary.json and OUT/summary.md."""
    suite.out.mkdir(parents=True, exist_ok=True)
    start = time.monotonic()
    deadline = start + suite.budget_s
    parts = []
    for name, part in (("hard", _hard), ("window", _window), ("soft", _soft)):
        if time.monotonic() > deadline:
            parts.append({"part": name, "status": "skipped: the time budget was spent"})
            continue
        t0 = time.monotonic()
        suite.log(f"suite: {name}")
        result = part(suite, deadline)
        parts.append({"part": name, "status": "ok", **result,
                      "seconds": round(time.monotonic() - t0, 1)})
    summary = {"suite": "gpu", "quick": suite.quick, "budget_s": suite.budget_s,
               "wall_s": round(time.monotonic() - start, 1), "parts": parts}
    outputs.write_json(suite.out / "summary.json", summary)
    outputs.write_bytes(suite.out / "summary.md", summary_text(summary).encode())
    return summary


def _hard(suite: Suite, deadline: float) -> dict:
    plan = suite.plan
    users = []
    if suite.real_level is not None and suite.real_level.is_file():
        users.append(runs.user_scene(suite.real_level, ()))
    opts = runs.BenchOptions(
        out=suite.out / "hard", quick=plan.quick, size=plan.size, frames=plan.frames,
        warmup=plan.warmup, error_frames=plan.error_frames, flicker_frames=0,
        scenes=["courtyard", *plan.towns], user_scenes=users,
        params={"single_resolution": plan.single_resolutions}, progress=suite.progress,
        log=suite.log, deadline=deadline)
    opts.reference = runner.reference_available()
    result = runner.run(opts)
    acceptance = result["summary"]
    return {"renderer": acceptance.get("renderer"), "clock": acceptance.get("clock"),
            "size": list(plan.size), "csv": result["csv"], "rows": result["rows"],
            "real_level": str(suite.real_level) if users else None,
            "comparisons": acceptance.get("default_comparisons", [])}


def _window(suite: Suite, deadline: float) -> dict:
    from game.app.window import walkaround

    plan = suite.plan
    stats_path = suite.out / "window.json"
    opts = walkaround.PlayOptions(size=plan.window_size, frames=plan.window_frames,
                                  stats=stats_path, platform="null", time_step=1.0 / 30.0)
    stats = walkaround.play(load_scene(reference_scene_path()), opts)
    frames = stats["frames"][1:] or stats["frames"]
    total = [f["ms"]["total"] for f in frames if "total" in f["ms"]]
    return {"renderer": stats["renderer"], "clock": stats["clock"], "size": stats["size"],
            "frames": len(stats["frames"]), "fps": stats["fps"],
            "total_ms_median": round(float(np.median(total)), 3) if total else None,
            "stats": str(stats_path)}


def _soft(suite: Suite, deadline: float) -> dict:
    plan = suite.plan
    scene = load_scene(reference_scene_path())
    ctx = context.create_headless()
    try:
        rows, header = soft_sweep.sweep(ctx, scene, plan.soft_size, plan.soft_samples,
                                        log=suite.log)
    finally:
        ctx.release()
    folder = suite.out / "soft"
    folder.mkdir(exist_ok=True)
    write_table(folder / "soft_sweep.csv", rows, soft_sweep.FIELDS)
    outputs.write_json(folder / "soft_sweep.json", {**header, "rows": rows})
    soft_sweep.write_chart(folder / "soft_sweep.png", rows, header)
    soft_sweep.write_counter_chart(folder / "soft_sweep_counters.png", rows, header)
    keep = ("method", "samples", "trace_ms", "embree_ms", "rmse_analytic", "rmse_embree",
            "truncated")
    return {"renderer": header["renderer"], "clock": header["clock"], "size": header["size"],
            "rows": [{k: r.get(k) for k in keep} for r in rows],
            "csv": str(folder / "soft_sweep.csv")}


def summary_text(summary: dict) -> str:
    """The summary as a short Markdown page: every figure with its renderer and clock."""
    lines = [f"# GPU suite{' (quick)' if summary['quick'] else ''}", "",
             f"Wall time {summary['wall_s']} s of a {summary['budget_s']:.0f} s budget.", ""]
    for part in summary["parts"]:
        lines.append(f"## {part['part']}")
        if part["status"] != "ok":
            lines += [part["status"], ""]
            continue
        lines.append(f"{part['renderer']}, clock {part['clock']}, "
                     f"{part['size'][0]}x{part['size'][1]}, {part['seconds']} s.")
        lines.append("")
        if part["part"] == "hard":
            if not part["real_level"]:
                lines.append("No real level: run `python assets/fetch_real.py` first.")
            for c in part["comparisons"]:
                baseline = " ".join(c["baseline"].split("|")[1:3]).replace(" defaults", "")
                lines.append(f"- {c['scene']}: clumped {c['clumped_ms']:.2f} ms, error "
                             f"{100 * c['clumped_error']:.2f}%; {baseline}: "
                             f"{c['baseline_ms']:.2f} ms, {100 * c['baseline_error']:.2f}%; "
                             f"baseline ms / clumped ms {c['speedup']:.2f}")
        elif part["part"] == "window":
            lines.append(f"- {part['fps']} fps over {part['frames']} frames; median frame "
                         f"total {part['total_ms_median']} ms")
        else:
            for r in part["rows"]:
                embree = f", Embree on the same rays {r['embree_ms']} ms" if r["embree_ms"] else ""
                lines.append(f"- {r['method']} N={r['samples']}: trace {r['trace_ms']} ms"
                             f"{embree}; RMSE against Embree's {soft_sweep.REFERENCE_SAMPLES} "
                             f"samples {r['rmse_embree']}; truncated points {r['truncated']}")
        lines.append("")
    lines.append("Every figure is also in summary.json; the CSVs and charts lie beside it.")
    return "\n".join(lines) + "\n"
