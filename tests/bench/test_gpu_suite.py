"""``bench --suite gpu``: the GPU checks in one command, here on llvmpipe with ``--quick``."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import time

from game.bench import gpu_suite, runner, runs
from tests.bench import gpu_suite_driver
from tests.bench.gpu_suite_driver import SMALL
from tests.helpers import ROOT


def test_quick_suite_writes_every_part_with_its_renderer_and_clock(tmp_path):
    out = tmp_path / "gpu"
    result = subprocess.run([sys.executable, "-m", "tests.bench.gpu_suite_driver",
                             "--out", str(out), "--no-progress"],
                            cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["quick"] is True
    assert [p["part"] for p in summary["parts"]] == ["hard", "window", "soft"]
    for part in summary["parts"]:
        assert part["status"] == "ok"
        assert part["renderer"] and part["clock"] in ("cpu-finish", "gpu-query")
    hard, window, soft = summary["parts"]
    real = gpu_suite_driver.REAL_LEVEL
    assert {c["scene"] for c in hard["comparisons"]} == {"courtyard", *SMALL.towns, real.stem}
    assert hard["real_level"] == str(real)
    assert {c["baseline"].split("|")[1] for c in hard["comparisons"]} == {
        "single", "csm", "static-dynamic"}
    assert window["fps"] > 0 and window["frames"] == SMALL.window_frames
    assert {r["samples"] for r in soft["rows"] if r["method"] != "analytic"} == set(
        SMALL.soft_samples)
    for path in ("hard/bench.csv", "hard/charts/pareto_courtyard.png", "soft/soft_sweep.csv",
                 "soft/soft_sweep.png", "window.json", "summary.md"):
        assert (out / path).stat().st_size > 0, path
    text = (out / "summary.md").read_text()
    assert hard["renderer"] in text and "clock cpu-finish" in text


def test_the_quick_plan_is_the_tested_one_with_more_frames():
    """The end-to-end run above uses the quick plan with fewer frames and samples and no town;
    the rest of the quick plan, and where the suite looks for the real level, are the ones
    tested."""
    quick = gpu_suite.QUICK
    assert dataclasses.replace(SMALL, towns=quick.towns, frames=quick.frames,
                               warmup=quick.warmup, window_frames=quick.window_frames,
                               soft_samples=quick.soft_samples) == quick
    assert quick.quick and quick.towns == ("town_2x2",)
    assert set(SMALL.soft_samples) < set(quick.soft_samples)
    assert gpu_suite.Suite(out=ROOT).real_level == gpu_suite.REAL_LEVEL
    assert gpu_suite.REAL_LEVEL == ROOT / "assets" / "real" / "monastery.toml"


def test_a_spent_budget_starts_no_part(tmp_path):
    summary = gpu_suite.run(gpu_suite.Suite(out=tmp_path, quick=True, budget_s=0.0,
                                            log=lambda line: None))
    assert [p["status"] for p in summary["parts"]] == ["skipped: the time budget was spent"] * 3
    assert "skipped" in (tmp_path / "summary.md").read_text()


def test_the_bench_starts_no_run_past_its_deadline(tmp_path):
    lines = []
    opts = runs.BenchOptions(out=tmp_path, quick=True, scenes=["default"], progress=False,
                             reference=False, deadline=time.monotonic() - 1.0,
                             log=lines.append)
    result = runner.run(opts)
    assert result["rows"] == 0
    assert any("time budget spent" in line for line in lines)
