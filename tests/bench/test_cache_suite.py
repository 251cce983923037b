"""``bench --suite cache``: the CPU twin under a cache simulator, natively and beside Embree."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

from game import cli
from game.bench import cache_grind, cache_suite
from game.errors import GameError
from game.soft import cpu_twin
from tests.helpers import ROOT

needs_tools = pytest.mark.skipif(
    not cpu_twin.numba_available() or cache_grind.missing_tools() is not None,
    reason=f"the cache suite needs numba and valgrind: "
           f"{cache_grind.missing_tools() or 'pip install -e .[cache]'}")


@needs_tools
def test_quick_suite_writes_the_csv_chart_and_record(tmp_path, monkeypatch, capsys):
    # In this process, where the twin's kernels are compiled once for every test; each native
    # timing is the fastest of its repeats alone, not of as many as fill half a second.
    monkeypatch.setattr(cache_suite, "MIN_TIMING_S", 0.0)
    out = tmp_path / "cache"
    args = ["bench", "--suite", "cache", "--quick", "--out", str(out)]
    monkeypatch.setattr(sys, "argv", ["python -m game", *args])
    assert cli.main(args) == 0, capsys.readouterr().err
    rows = list(csv.DictReader((out / "cache.csv").open()))
    assert set(cache_suite.FIELDS) <= set(rows[0])
    jobs = {(r["method"], int(r["samples"])) for r in rows}
    assert jobs == {(m, n) for m in cache_suite.METHODS for n in cache_suite.QUICK_SAMPLES
                    if m != "brute" or n <= cache_suite.BRUTE_MAX_SAMPLES}
    for r in rows:
        points = int(r["points"])
        assert int(r["gpu_equal"]) == points and int(r["gpu_differ"]) == 0, r["method"]
        assert float(r["ms_per_ray"]) > 0 and float(r["embree_ms_per_ray"]) > 0
        assert int(r["rays"]) > 0 and int(r["threads"]) >= 1
        # Under valgrind the twin finds the same visibility it finds natively.
        assert int(r["grind_equal"]) == points
        assert float(r["d_refs_per_ray"]) > float(r["d1_misses_per_ray"]) > 0
        assert float(r["d1_misses_per_ray"]) >= float(r["ll_misses_per_ray"]) > 0
    assert (out / "cache.png").stat().st_size > 0
    record = json.loads((out / "run.json").read_text())
    assert "--suite cache" in record["command"] and record["date"].endswith("UTC")
    assert record["machine"]["cpu"] and record["cache_simulation"]["D1"]


def test_a_sweep_flag_is_one_line_and_exit_2():
    result = subprocess.run([sys.executable, "-m", "game", "bench", "--suite", "cache",
                             "--scenes", "courtyard"],
                            cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr


@needs_tools
def test_a_missing_scene_is_a_game_error(tmp_path):
    with pytest.raises(GameError, match="no scene file"):
        cache_suite.run(cache_suite.CacheSuite(out=tmp_path, scenes=("nowhere.toml",)))


@needs_tools
def test_an_absent_real_level_is_skipped_with_a_note(tmp_path):
    suite = cache_suite.CacheSuite(out=tmp_path, scenes=("assets/real/absent.toml",))
    with pytest.raises(GameError, match="fetch_real"):
        cache_suite.run(suite)
    assert "skipped assets/real/absent.toml" in suite.notes[0]
