"""The benchmark at tiny scale: CSV columns, resuming and skipping rows, charts, flicker, Pareto."""

import numpy as np
import pytest

from game import cli
from game.bench import acceptance, charts, measure, runs
from game.bench import runner as bench
from game.bench.rows import read_rows
from game.shadows import registry
from game.shadows.methods.cascaded import CascadedShadows

pytest.importorskip("matplotlib", reason="bench charts need matplotlib (pip install .[bench])")
pytest.importorskip("tqdm", reason="bench needs tqdm (pip install .[bench])")


def tiny_options(tmp_path, **kw) -> runs.BenchOptions:
    base = dict(out=tmp_path / "bench", quick=True, size=(80, 45), frames=2, warmup=1,
                error_frames=1, flicker_frames=2, scenes=["stab_thin"],
                methods=["clumped", "single"], progress=False, log=lambda line: None)
    base.update(kw)
    return runs.BenchOptions(**base)


def test_bench_writes_rows_and_charts_then_skips_them(ctx, tmp_path):
    pytest.importorskip("embreex")
    opts = tiny_options(tmp_path)
    result = bench.run(opts, ctx)
    rows = read_rows(opts.out / "bench.csv")
    assert [r["method"] for r in rows] == ["clumped", "single"]
    assert list(rows[0]) == runs.COLUMNS
    for r in rows:
        assert r["status"] == "ok"
        assert r["renderer"] and r["version"] and r["clock"] in ("cpu-finish", "gpu-query")
        assert float(r["total_ms_median"]) > 0 and float(r["total_ms_p95"]) > 0
        assert 0.0 <= float(r["error"]) <= 1.0 and int(r["shadowed"]) > 0
        assert 0.0 <= float(r["flicker"]) <= 1.0
        assert int(float(r["nan_pixels"])) == 0
        assert float(r["shadow_memory_mib"]) > 0
        assert float(r["map_candidates_per_fragment"]) > 0  # counted on the last frame
        assert 0.0 <= float(r["depth_first"]) <= 1.0  # the share of frames drawn depth first
    # single re-renders its whole map every frame; clumped only its character map, at most
    # 512^2 and sized for the view.
    clumped, single = rows
    assert float(single["texels_to_maps"]) == 4096 ** 2
    assert 0 < float(clumped["texels_to_maps"]) <= 512 ** 2
    charts = {p.name for p in (opts.out / "charts").iterdir()}
    assert {"stability_thin.png", "stability_thin.svg"} <= charts
    assert result["rows"] == 2

    def must_not_run(*args, **kw):
        raise AssertionError("a finished row was measured again")

    original = bench.run_one
    bench.run_one = must_not_run
    try:
        again = bench.run(opts, ctx)
    finally:
        bench.run_one = original
    assert again["rows"] == 2


def test_an_interrupted_bench_keeps_finished_rows(ctx, tmp_path, monkeypatch):
    opts = tiny_options(tmp_path, reference=False)
    calls = []
    original = bench.run_one

    def interrupt_second(*args, **kw):
        calls.append(args[3].method)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return original(*args, **kw)

    monkeypatch.setattr(bench, "run_one", interrupt_second)
    with pytest.raises(KeyboardInterrupt):
        bench.run(opts, ctx)
    rows = read_rows(opts.out / "bench.csv")
    assert [r["method"] for r in rows] == ["clumped"]
    assert not list(opts.out.glob("bench-*")), "temp dump folders left behind"
    monkeypatch.setattr(bench, "run_one", original)
    bench.run(opts, ctx)
    rows = read_rows(opts.out / "bench.csv")
    assert [r["method"] for r in rows] == ["clumped", "single"]
    assert rows[0]["error"] == ""  # no reference asked: left empty, not made up


def test_a_failing_method_gives_a_failed_row_not_a_crash(ctx, tmp_path, monkeypatch):
    opts = tiny_options(tmp_path, reference=False, methods=["csm"])

    class Broken(CascadedShadows):
        def __init__(self, *args, **kw):
            raise RuntimeError("no cascades today")

    monkeypatch.setitem(registry.METHODS, "csm", Broken)
    bench.run(opts, ctx)
    (row,) = read_rows(opts.out / "bench.csv")
    assert row["status"] == "failed: RuntimeError: no cascades today"


def _frame(lit, exact, view):
    h, w = lit.shape
    ys, xs = np.mgrid[0:h, 0:w]
    # A plane at z = -5 seen by a camera at the origin: pixel (r, c) sees a point of its own.
    proj = np.eye(4)
    proj[3, 2], proj[3, 3] = -1.0, 0.0
    ndc_x = (xs + 0.5) / w * 2 - 1
    ndc_y = 1 - (ys + 0.5) / h * 2
    position = np.stack([ndc_x * 5, ndc_y * 5, np.full_like(ndc_x, -5.0)], -1)
    return {"position": position.astype(np.float32), "object": np.zeros((h, w), np.int32),
            "lit": lit, "exact": exact, "view": view, "proj": proj}


def test_flicker_counts_only_the_methods_own_flips():
    view = np.eye(4)
    lit = np.ones((10, 10), np.float32)
    exact = np.ones((10, 10), np.float32)
    a = _frame(lit, exact, view)
    flipped = lit.copy()
    flipped[:2] = 0.0   # 20 pixels flip in the method only
    both = exact.copy()
    both[:1] = 0.0      # 10 of them also flip in the reference
    b = _frame(flipped, both, view)
    rates = measure.flicker_rates([a, b])
    assert rates["flicker_raw"] == pytest.approx(0.2)
    assert rates["flicker_reference"] == pytest.approx(0.1)
    assert rates["flicker"] == pytest.approx(0.1)
    assert measure.flicker_rates([a, a])["flicker"] == 0.0


def test_pareto_front_and_comparison():
    pts = [(10.0, 0.01), (5.0, 0.05), (20.0, 0.005), (12.0, 0.02), (5.0, 0.06)]
    assert charts.pareto_front(pts) == [0, 1, 2]
    rows = [
        {"run": "s|clumped|defaults|1x1", "scene": "s", "method": "clumped", "status": "ok",
         "error": "0.02", "total_ms_median": "10"},
        {"run": "s|single|r=1|1x1", "scene": "s", "method": "single", "status": "ok",
         "error": "0.5", "total_ms_median": "5"},
        {"run": "s|single|r=2|1x1", "scene": "s", "method": "single", "status": "ok",
         "error": "0.03", "total_ms_median": "100"},
        {"run": "s|single|r=3|1x1", "scene": "s", "method": "single", "status": "ok",
         "error": "0.01", "total_ms_median": "400"},
    ]
    c = acceptance.compare(rows, "s", "single")
    # The most accurate baseline run that is still no better than clumped: r=2, not r=1.
    assert c["baseline"] == "s|single|r=2|1x1" and c["speedup"] == pytest.approx(10.0)
    assert c["clumped_error_lower"]


def test_cli_lists_runs_and_rejects_a_bad_method(tmp_path, capsys):
    assert cli.main(["bench", "--quick", "--list", "--out", str(tmp_path)]) == 0
    listed = capsys.readouterr().out.split()
    assert "default|clumped|defaults|320x180" in listed
    assert any(r.startswith("stab_elevation_90|csm|") for r in listed)
    assert cli.main(["bench", "--methods", "nope"]) == 2
    err = capsys.readouterr().err
    assert "unknown method 'nope'" in err and "Traceback" not in err


def test_repeated_timings_take_turns_frame_by_frame_and_are_combined(ctx, tmp_path, monkeypatch):
    opts = tiny_options(tmp_path, reference=False, repeat=2)
    order = []
    original = measure.Timing.frame

    def spy(self):
        order.append((self.spec.method, self.k))
        return original(self)

    monkeypatch.setattr(measure.Timing, "frame", spy)
    bench.run(opts, ctx)
    frames = opts.warmup + opts.frames
    # Each repetition: frame k of every run, then frame k + 1 of every run.
    turn = [(m, k) for k in range(frames) for m in ("clumped", "single")]
    assert order == turn + turn
    rows = read_rows(opts.out / "bench.csv")
    for r in rows:
        assert r["status"] == "ok" and r["repeats"] == "2"
        assert float(r["total_ms_spread"]) >= 0.0


def test_a_run_that_fails_mid_way_leaves_the_others_timed(ctx, tmp_path, monkeypatch):
    opts = tiny_options(tmp_path, reference=False, repeat=2)
    original = measure.Timing.frame

    def failing(self):
        if self.spec.method == "single" and self.k == 1:
            raise RuntimeError("out of memory")
        return original(self)

    monkeypatch.setattr(measure.Timing, "frame", failing)
    bench.run(opts, ctx)
    rows = {r["method"]: r for r in read_rows(opts.out / "bench.csv")}
    assert rows["clumped"]["status"] == "ok" and rows["clumped"]["repeats"] == "2"
    assert rows["single"]["status"].startswith("failed: RuntimeError: out of memory")


def test_combine_takes_the_median_of_repetitions():
    reps = [{f"{p}_ms_{s}": v for p in runs.PASSES for s in ("median", "p95", "min")}
            for v in (10.0, 30.0, 12.0)]
    row = measure.combine(reps)
    assert row["total_ms_median"] == 12.0 and row["repeats"] == 3
    assert row["total_ms_min"] == 10.0
    assert row["total_ms_spread"] == pytest.approx(20.0 / 12.0)
