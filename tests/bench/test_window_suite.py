"""``bench --suite window``: the window's frame rate as ``play`` opens it, each run in its own
process (game/bench/window_suite.py), and its section of the results page
(game/bench/report_window.py), whose ratios come from the CSV."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

from game.bench.report import write_report
from game.bench.rows import write_table
from game.bench.window_suite import COLUMNS, RUNS
from tests.bench.report_data import RECORD, fake_checkout
from tests.cli.cli_helpers import assert_one_line_error, run


def test_the_quick_suite_runs_each_window_in_turn_as_play_opens_it(tmp_path):
    out = tmp_path / "window"
    result = run("bench", "--suite", "window", "--quick", "--out", str(out))
    assert result.returncode == 0, result.stderr
    with (out / "window.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(RUNS)
    assert [r["method"] for r in rows[:2]] == ["clumped", "single"]
    assert all(r["as_shown"] == "True" and r["pcf"] == "True" for r in rows)
    assert all(float(r["fps_cpu"]) > 0 and float(r["shade_ms"]) > 0 for r in rows)
    soft = [r for r in rows if r["soft"] == "True"]
    assert len(soft) == 2 and all(r["soft_method"] for r in soft)
    record = json.loads((out / "run.json").read_text())
    assert "--suite window" in record["command"] and record["renderer"] == rows[0]["renderer"]


@pytest.mark.parametrize("flags, fragment", [
    (["--methods", "single"], "--methods belongs"), (["--size", "320x180"], "--size"),
    (["--clock", "cpu-thread"], "--clock"), (["--report"], "--report")])
def test_a_flag_the_suite_takes_no_notice_of_is_refused_in_one_line(tmp_path, flags, fragment):
    result = run("bench", "--suite", "window", *flags, "--out", str(tmp_path / "out"))
    assert_one_line_error(result, fragment)
    assert not (tmp_path / "out").exists()


def test_an_out_that_cannot_be_made_leaves_no_folder(tmp_path):
    out = tmp_path / "deep" / ("x" * 300) / "x"
    result = run("bench", "--suite", "window", "--quick", "--out", str(out))
    assert_one_line_error(result, "File name too long")
    assert not (tmp_path / "deep").exists()


@pytest.mark.parametrize("flags", [["--frames", "0"], ["--turn", "nan"], ["--turn", "181"]])
def test_the_window_runs_bad_numbers_are_one_line(flags):
    result = subprocess.run([sys.executable, "-m", "game.bench.soft_window", "fps", *flags],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip().splitlines()[-1].startswith("python -m game.bench.soft_window")


def _fps(method: str, soft: bool, turn: float, round_: int, fps: float) -> dict:
    return {"round": round_, "order": 0, "method": method, "soft": soft,
            "soft_method": "segment-maps" if soft else "", "turn_degrees": turn,
            "sweep_degrees": 30.0 if turn else 0.0, "pcf": True, "as_shown": True, "width": 960,
            "height": 540, "frames": 300, "fps_cpu": fps, "fps_wall": 2 * fps,
            "ms_cpu": 1e3 / fps, "shade_ms": 20.0, "renderer": RECORD["renderer"],
            "version": RECORD["version"]}


@pytest.fixture
def root(tmp_path):
    """A checkout with one bench run and one window run of two rounds."""
    fake_checkout(tmp_path)
    window = tmp_path / "docs" / "runs" / "window"
    window.mkdir()
    rows = []
    for round_, scale in ((1, 1.0), (2, 0.8)):
        rows += [_fps("clumped", False, 0.0, round_, 20 * scale),
                 _fps("single", False, 0.0, round_, 16 * scale),
                 _fps("clumped", False, 1.0, round_, 24 * scale),
                 _fps("clumped", True, 0.0, round_, 12 * scale),
                 _fps("clumped", True, 1.0, round_, 10 * scale)]
    write_table(window / "window.csv", rows, COLUMNS)
    (window / "run.json").write_text(json.dumps({**RECORD, "command": "python -m game bench "
                                                 "--suite window --out docs/runs/window"}))
    return tmp_path


def test_the_window_section_gives_each_rounds_frame_rates_and_ratios(root):
    write_report(root)
    page = (root / "docs" / "results.md").read_text()
    section = page[page.index("## The window's frame rate"):]
    section = section[:section.index("\n## ", 1)]
    assert "--suite window --out docs/runs/window" in section
    assert "| clumped, camera still | 20.00 | 16.00 | 20.0 |" in section
    assert "| clumped, soft shadows, camera turning 1 degree a frame | 10.00 | 8.00" in section
    assert "within 30 degrees" in section and "at 960x540" in section
    assert "single's, camera still: 1.25 and 1.25" in section
    assert "camera still 0.60 and 0.60, turning 0.42 and 0.42" in section


def test_rounds_are_paired_by_their_number_and_a_missing_one_shows_as_a_dash(root):
    path = root / "docs" / "runs" / "window" / "window.csv"
    with path.open(newline="") as f:
        rows = [r for r in csv.DictReader(f) if not (r["method"] == "single" and r["round"] == "1")]
    write_table(path, rows, COLUMNS)
    write_report(root)
    page = (root / "docs" / "results.md").read_text()
    assert "| single, camera still | - | 12.80 | 20.0 |" in page
    assert "single's, camera still: 1.25 (round by round)" in page


@pytest.mark.parametrize("column, value, fragment", [
    (None, None, "window suite's columns"), ("round", "x", "round"), ("fps_cpu", "0", "fps_cpu"),
    ("soft", "maybe", "soft")])
def test_a_garbled_window_run_is_refused_in_one_line(root, column, value, fragment):
    path = root / "docs" / "runs" / "window" / "window.csv"
    if column is None:
        path.write_text("round,method\n1,clumped\n")
    else:
        with path.open(newline="") as f:
            rows = list(csv.DictReader(f))
        rows[1][column] = value
        write_table(path, rows, COLUMNS)
    result = run("bench", "--report", str(root))
    assert_one_line_error(result, fragment)
