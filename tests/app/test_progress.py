"""Progress of long headless runs (game/app/progress.py): the line itself with a stand-in clock,
then ``trace`` with its standard error on a pseudo-terminal."""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys

import pytest

from game.app.progress import REDRAW_S, SHOW_AFTER_S, Progress
from tests.helpers import COURTYARD, ROOT, TINY


class Terminal:
    """A stream that says it is a terminal and keeps what is written to it."""

    def __init__(self, tty: bool = True):
        self.tty = tty
        self.text = ""

    def isatty(self) -> bool:
        return self.tty

    def write(self, text: str) -> None:
        self.text += text

    def flush(self) -> None:
        pass


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def run(progress: Progress, clock: Clock, frames: int, frame_s: float, parts: int) -> None:
    """``frames`` frames of ``frame_s`` each, reporting ``parts`` shares of each."""
    for _ in range(frames):
        progress.frame()
        for k in range(1, parts + 1):
            clock.now += frame_s / parts
            progress.part(k / parts)
    progress.close(done=True)


def test_a_short_run_shows_nothing():
    stream, clock = Terminal(), Clock()
    run(Progress("trace", 3, stream, clock), clock, frames=3, frame_s=0.5, parts=4)
    assert stream.text == ""


def test_a_long_frame_shows_one_line_redrawn_in_place():
    stream, clock = Terminal(), Clock()
    run(Progress("trace", 1, stream, clock), clock, frames=1, frame_s=10.0, parts=100)
    assert stream.text.endswith("\n") and stream.text.count("\n") == 1
    draws = [d.removesuffix("\x1b[K") for d in stream.text.rstrip("\n").split("\r")[1:]]
    # Not one draw per part: at most one every REDRAW_S once SHOW_AFTER_S has passed.
    assert 3 <= len(draws) <= (10.0 - SHOW_AFTER_S) / REDRAW_S + 2
    assert draws[0].startswith("trace: frame 1/1") and draws[-1] == "trace: frame 1/1  100%  10.0 s"
    percents = [int(d.split()[3].rstrip("%")) for d in draws]
    assert percents == sorted(percents) and 15 <= percents[0] <= 30


def test_many_short_frames_count_the_frames():
    stream, clock = Terminal(), Clock()
    run(Progress("capture", 40, stream, clock), clock, frames=40, frame_s=0.1, parts=1)
    draws = stream.text.rstrip("\n").split("\r")[1:]
    assert draws[0].startswith("capture: frame 2") and "capture: frame 40/40  100%" in draws[-1]


def test_not_a_terminal_shows_nothing():
    stream, clock = Terminal(tty=False), Clock()
    progress = Progress("trace", 1, stream, clock)
    run(progress, clock, frames=1, frame_s=10.0, parts=100)
    assert stream.text == "" and not progress.enabled


def test_a_stopped_run_ends_its_line_where_it_stopped():
    stream, clock = Terminal(), Clock()
    progress = Progress("trace", 4, stream, clock)
    progress.frame()
    clock.now += 3.0
    progress.part(0.5)
    progress.close(done=False)
    assert stream.text.rstrip("\n").split("\r")[-1].startswith("trace: frame 1/4   12%")


def _trace_on_a_terminal(tmp_path, *args) -> tuple[str, str, dict]:
    """``python -m game trace`` with standard error on a pseudo-terminal: (what the terminal
    showed, standard output, the stats)."""
    stats = tmp_path / "stats.json"
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYTHONPATH"] = str(ROOT)
    main, child = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "game", "trace", *map(str, args), "--out",
                             str(tmp_path / "out"), "--stats", str(stats)],
                            stdout=subprocess.PIPE, stderr=child, stdin=subprocess.DEVNULL,
                            cwd=ROOT, env=env)
    os.close(child)
    shown = b""
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:   # the child closed the terminal (Linux: EIO)
            break
        if not chunk:
            break
        shown += chunk
    os.close(main)
    out, _ = proc.communicate(timeout=300)
    assert proc.returncode == 0, shown.decode(errors="replace")
    return shown.decode(errors="replace"), out.decode(), json.loads(stats.read_text())


def test_a_long_trace_shows_progress_on_a_terminal_and_not_on_stdout(tmp_path):
    # Brute force over the courtyard: seconds on llvmpipe, in bands of rows.
    shown, out, stats = _trace_on_a_terminal(tmp_path, COURTYARD, "--method", "brute",
                                             "--samples", "4", "--size", "160x90")
    if stats["frames"][0]["total"] < 1.5e3 * SHOW_AFTER_S:
        pytest.skip("this machine traces it too fast to need progress")
    lines = [d for d in shown.split("\r") if d.startswith("trace: frame 1/1")]
    assert len(lines) >= 2 and "100%" in lines[-1], shown
    assert "trace:" not in out and out.startswith("wrote 1 frame(s)")


def test_a_short_trace_shows_none(tmp_path):
    shown, out, stats = _trace_on_a_terminal(tmp_path, TINY, "--samples", "1", "--size",
                                             "64x36")
    assert stats["frames"][0]["total"] < 1e3 * SHOW_AFTER_S
    assert "trace:" not in shown and out.startswith("wrote 1 frame(s)")
