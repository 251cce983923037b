"""The results page generated from recorded runs (game/bench/report.py), on a tiny fake run: its
tables, headers and figures, the README's block, and one-line errors for a bad run folder. No GL."""

from __future__ import annotations

import csv
import json

import pytest

from game.bench.report import BEGIN, END, write_report
from game.errors import GameError
from tests.bench.report_data import README, fake_checkout
from tests.cli.cli_helpers import assert_one_line_error, run


@pytest.fixture
def root(tmp_path):
    """A checkout with one recorded run, ``docs/runs/fake``, and a README with a figure block."""
    return fake_checkout(tmp_path)


def test_each_table_is_headed_by_its_run(root):
    write_report(root)
    text = (root / "docs" / "results.md").read_text()
    head = ("Run [`fake`](runs/fake/run.json): `python -m game bench --scenes courtyard "
            "--repeat 3 --out docs/runs/fake`; llvmpipe (LLVM 15.0.6, 256 bits), OpenGL 4.5 "
            "(Core Profile); 2026-01-02 03:04 UTC; code `0123456789`.")
    # Question 1, question 2, its shading pass and the camera pass at equal accuracy (one map
    # at two sides), and the run's own table: five tables, each under the header.
    assert text.count(head) == 5
    assert text.index("## Question 1") < text.index("## Question 2") < text.index(
        "## Every recorded run")


def test_the_figures_are_the_runs_medians_and_their_ratios(root):
    write_report(root)
    text = (root / "docs" / "results.md").read_text()
    # Q1: world / light, the frame with the spread of its three repeats.
    assert ("| courtyard | 320x180 | defaults | 12.0 (25%) / 10.0 (12%) | 2.00 / 2.00 "
            "| 0.40% / 0.20% | 108 / 145 |") in text
    assert "error: world lower in 0 of 1, light in 1; frame: world lower in 0 of 1, light in 1" \
        in text
    # Q2: frame over clumped's, shadow maps (static + dynamic) and camera (cull + shade).
    assert "| `single` | defaults | 1 | 7 | 64 | 30.0 (5%) | 2.00 | 5.00 | 0.50% | 3.00 |" in text
    assert ("| `single` | single_resolution=1024 | 1 | 7 | 64 | 8.00 (5%) | 2.00 | 5.00 | 2.00% "
            "| 0.80 |") in text
    assert "frame: clumped lower in 1 of 2, `single` in 1; error: clumped lower in 2 of 2" in text
    # The camera pass beside the error: clumped, then one map from its smallest side up.
    assert ("| courtyard | 320x180 | clumped | 5.0 | 10.0 | 0.20% |\n"
            "| courtyard | 320x180 | single 1024^2 | 5.0 | 8.0 | 2.00% |\n"
            "| courtyard | 320x180 | single 4096^2 | 5.0 | 30.0 | 0.50% |") in text


def test_the_readme_block_is_replaced_and_the_rest_kept(root):
    write_report(root)
    text = (root / "README.md").read_text()
    assert text.startswith("# A project\n\nWords before.\n\n" + BEGIN)
    assert text.endswith(END + "\n\nWords after.\n")
    assert "old figures" not in text
    assert ("| courtyard | 320x180 | 10.0, 0.20% | 30.0, 0.50% | 0.33 "
            "| [fake](docs/runs/fake/run.json) |") in text


def test_a_second_report_writes_the_same_bytes(root):
    write_report(root)
    first = [(root / p).read_bytes() for p in ("README.md", "docs/results.md")]
    write_report(root)
    assert [(root / p).read_bytes() for p in ("README.md", "docs/results.md")] == first


def test_a_readme_without_the_block_is_refused_and_nothing_written(root):
    (root / "README.md").write_text("# A project\n")
    with pytest.raises(GameError, match="figures:begin"):
        write_report(root)
    assert not (root / "docs" / "results.md").exists()


@pytest.mark.parametrize("damage, fragment", [
    (lambda f: (f / "run.json").unlink(), "no run.json"),
    (lambda f: (f / "run.json").write_text("{not json"), "not a run record"),
    (lambda f: (f / "run.json").write_text('{"command": "x"}'), "no renderer, version, date"),
    (lambda f: (f / "bench.csv").write_text("garbage,here\n1,2\n"), "not a bench CSV"),
    (lambda f: (f / "bench.csv").unlink(), "no bench.csv"),
])
def test_a_bad_run_folder_gets_one_line(root, damage, fragment):
    damage(root / "docs" / "runs" / "fake")
    result = run("bench", "--report", root)
    assert_one_line_error(result, "fake", fragment)
    assert (root / "README.md").read_text() == README


def test_no_runs_gets_one_line(tmp_path):
    assert_one_line_error(run("bench", "--report", tmp_path), "no recorded runs")


def test_the_bench_records_what_the_report_reads(root):
    from game.bench.report import load_run
    from game.bench.runner import write_run_record

    folder = root / "docs" / "runs" / "fake"
    write_run_record(folder, "python -m game bench --out x", {"renderer": "r", "version": "v"})
    record = load_run(folder).record
    assert record["command"] == "python -m game bench --out x"
    assert (record["renderer"], record["version"]) == ("r", "v")
    assert record["date"].endswith(" UTC")
    assert "commit" not in record  # a folder outside any checkout


def test_a_run_timed_by_thread_time_says_so_in_its_header(root):
    from game.bench.runner import write_run_record

    folder = root / "docs" / "runs" / "fake"
    write_run_record(folder, "python -m game bench --clock cpu-thread --out x",
                     {"renderer": "llvmpipe", "version": "4.5"}, "cpu-thread")
    assert json.loads((folder / "run.json").read_text())["clock"] == "cpu-thread"
    write_report(root)
    text = (root / "docs" / "results.md").read_text()
    assert "OpenGL 4.5; timed by one thread's CPU time;" in text
    write_run_record(folder, "python -m game bench --out x",
                     {"renderer": "llvmpipe", "version": "4.5"})
    write_report(root)
    assert "timed by one thread's CPU time;" not in (root / "docs" / "results.md").read_text()


def test_the_run_record_names_the_checkouts_commit():
    from game.bench.runner import git_commit
    from tests.helpers import ROOT

    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    code = git_commit(ROOT / "docs")
    assert len(code["commit"]) == 40 and isinstance(code["dirty"], bool)


def cache_row(scene: str, method: str, n: int, l1: float, ms: float) -> dict:
    return {"scene": scene, "method": method, "samples": n, "points": 10,
            "d1_misses_per_ray": l1, "ll_misses_per_ray": l1 / 2, "ms_per_ray_1thread": ms,
            "d1_misses_per_point": 3 * l1, "ll_misses_per_point": 1.5 * l1,
            "embree_ms_per_ray": 0.001, "gpu_differ": 0}


def test_a_cache_run_gets_its_answer_from_its_figures(root):
    folder = root / "docs" / "runs" / "cache"
    folder.mkdir()
    rows = [cache_row("s", m, n, l1, ms) for n in (1, 8)
            for m, l1, ms in (("grid", 2.0, 0.004), ("tri-cache", 3.0, 0.005),
                              ("voxel-cache", 1.0 if n == 8 else 4.0, 0.003))]
    with (folder / "cache.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (folder / "run.json").write_text(json.dumps({"command": "python -m game bench --suite "
                                                 "cache", "date": "2026-01-01 00:00 UTC"}))
    write_report(root)
    page = (root / "docs" / "results.md").read_text()
    assert ("Of 2 (scene, N) pairs, `voxel-cache` has fewer L1 misses per ray than both "
            "`grid` and `tri-cache` in 1, fewer last-level misses in 1, and a shorter time per "
            "ray on one thread in 2") in page
    assert "3.0 to 5.0 times Embree's" in page and "on 0 of 60 points" in page


def test_each_added_light_is_the_camera_pass_grown_over_the_lights_added(tmp_path):
    from types import SimpleNamespace

    from game.bench.report_shading import per_light_lines

    def row(method, lights, cull, shade):
        return {"method": method, "group": "lights", "factor": "lights", "lights": str(lights),
                "cull_ms_median": str(cull), "shade_ms_median": str(shade), "status": "ok"}

    pairs = [(row("clumped", n, 1.0, 10.0 + 2.0 * n), row("single", n, 1.0, 12.0 + 3.0 * n))
             for n in (4, 1, 16)]
    run = SimpleNamespace(name="lights", folder=tmp_path)
    text = "\n".join(per_light_lines(run, pairs, tmp_path))
    # 1 to 16 lights: clumped 13.0 -> 43.0 ms, (43 - 13) / 15 = +2.0 a light; single +3.0.
    assert "with 1, 4, 16 lights" in text
    assert "clumped's camera pass goes from 13.0 to 43.0 ms, +2.0 ms a light" in text
    assert "`single`'s from 16.0 to 61.0 ms, +3.0 ms a light" in text
    # One light count, or rows of another series, say nothing.
    assert per_light_lines(run, pairs[:1], tmp_path) == []
    other = [({**c, "factor": "characters"}, s) for c, s in pairs]
    assert per_light_lines(run, other, tmp_path) == []
    # A run that failed at 16 lights is left out: the step is from 1 to 4.
    failed = [(c, {**s, "status": "failed", "shade_ms_median": "nan"}) if c["lights"] == "16"
              else (c, s) for c, s in pairs]
    text = "\n".join(per_light_lines(run, failed, tmp_path))
    assert "with 1, 4 lights" in text and "13.0 to 19.0 ms, +2.0 ms a light" in text
    # Two pairs of one light count (two frame sizes) give no one step.
    assert per_light_lines(run, pairs + pairs[:1], tmp_path) == []
