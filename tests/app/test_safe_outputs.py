"""Safe outputs: an interrupted run leaves no truncated file and no half frame.

Every file goes through game/app/outputs.py (temp file beside it, fsync, rename); these tests stop
real capture processes at random points, with Ctrl-C (SIGINT) and with SIGKILL, and then read
every file under its final name: each must be whole. SIGINT also removes the temp file being
written; SIGKILL cannot, but leaves it only under a hidden ``.name.*.tmp`` name.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from game.app import frame_log, outputs
from tests.helpers import ROOT, TINY, decode_png, stoppable


def start_capture(out: Path, stats: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "game", "capture", str(TINY), "--size", "48x27",
         "--frames", "100000", "--dump", "--out", str(out), "--stats", str(stats)],
        cwd=ROOT, preexec_fn=stoppable, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_frames(out: Path, n: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while len(list(out.glob("frame_*.glb"))) < n:
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline, "capture too slow"
        time.sleep(0.02)


def check_whole(out: Path) -> int:
    """Every visible file decodes whole; returns the number of frames found."""
    pngs = sorted(out.glob("frame_*.png"))
    for png in pngs:
        assert decode_png(png.read_bytes()).shape == (27, 48, 3), png
    for npz in out.glob("frame_*.npz"):
        with np.load(npz) as dump:
            assert dump["lit"].shape == (27, 48), npz
    for glb in out.glob("frame_*.glb"):
        scene = trimesh.load(glb, file_type="glb", force="scene")
        assert len(scene.geometry) == 4, glb
    return len(pngs)


@pytest.mark.parametrize("delay", [0.0, 0.013, 0.031])
def test_ctrl_c_leaves_whole_files_and_no_temp(tmp_path, delay):
    out, stats = tmp_path / "out", tmp_path / "stats.json"
    proc = start_capture(out, stats)
    wait_for_frames(out, 3, proc)
    time.sleep(delay)  # land the interrupt at different points of a frame
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130
    assert err.strip().splitlines() == ["interrupted"]
    frames = check_whole(out)
    assert frames >= 3
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]
    # A frame is whole or absent: its PNG, NPZ and GLB appear together.
    stems = {kind: sorted(p.stem for p in out.glob(f"frame_*.{kind}"))
             for kind in ("png", "npz", "glb")}
    assert stems["png"] == stems["npz"] == stems["glb"]
    # The stats of exactly the frames on disk, marked as interrupted.
    document = json.loads(stats.read_text())
    assert document["interrupted"] is True
    assert [f"frame_{f['frame']:04d}" for f in document["frames"]] == stems["png"]


@pytest.mark.parametrize("command", [
    ["trace", str(TINY), "--size", "32x18", "--samples", "2", "--frames", "100000", "--dump"],
    ["play", str(TINY), "--size", "64x36", "--frames", "100000", "--platform", "null"],
])
def test_ctrl_c_keeps_the_stats_of_trace_and_play(tmp_path, command):
    out, stats = tmp_path / "out", tmp_path / "stats.json"
    extra = ["--out", str(out)] if command[0] == "trace" else []
    proc = subprocess.Popen([sys.executable, "-m", "game", *command, *extra, "--stats",
                             str(stats)], cwd=ROOT, preexec_fn=stoppable,
                            stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    # trace: wait for frames on disk; play: give the window time to show a few frames.
    while (len(list(out.glob("frame_*.glb"))) < 2 if command[0] == "trace"
           else time.monotonic() < deadline - 110):
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and err.strip().splitlines() == ["interrupted"]
    document = json.loads(stats.read_text())
    assert document["interrupted"] is True and len(document["frames"]) >= 1
    if command[0] == "trace":
        assert len(document["frames"]) == len(list(out.glob("frame_*.glb")))


@pytest.mark.parametrize("delay", [0.0, 0.017])
def test_kill_leaves_no_truncated_file_under_its_name(tmp_path, delay):
    out, stats = tmp_path / "out", tmp_path / "stats.json"
    proc = start_capture(out, stats)
    wait_for_frames(out, 3, proc)
    time.sleep(delay)
    proc.kill()
    proc.communicate(timeout=60)
    assert check_whole(out) >= 3
    leftovers = [p.name for p in out.iterdir() if not p.name.startswith("frame_")]
    assert all(name.startswith(".frame_") and name.endswith(".tmp") for name in leftovers)


def test_interrupted_stats_write_keeps_the_old_file(tmp_path, monkeypatch):
    log = frame_log.FrameLog()
    for k in range(5):
        log.append({"frame": k})
    target = tmp_path / "stats.json"
    log.write_json(target, {"renderer": "x", "frames": log})
    assert json.loads(target.read_text())["frames"] == [{"frame": k} for k in range(5)]
    before = target.read_bytes()
    real_line = log.line

    def interrupted(i):
        if i == 3:
            raise KeyboardInterrupt
        return real_line(i)

    monkeypatch.setattr(log, "line", interrupted)
    with pytest.raises(KeyboardInterrupt):
        log.write_json(target, {"renderer": "y", "frames": log})
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["stats.json"]


def test_every_writer_goes_through_outputs():
    # The audit as a test: no module but outputs.py opens a file for writing.
    offenders = []
    for path in (ROOT / "game").rglob("*.py"):
        if path.name == "outputs.py":
            continue
        text = path.read_text()
        for pattern in (r"open\([^)]*['\"][wax]", r"(?<!outputs)\.write_(text|bytes)\(",
                        r"np\.save\(", r"(?<!np\.)savez(_compressed)?\(", r"savefig\(",
                        r"json\.dump\("):
            if re.search(pattern, text):
                offenders.append(f"{path.name}: {pattern}")
    assert not offenders
    assert outputs.FILE_MODE


PRELUDE = """
import os, signal, sys
from game.app import interrupts
signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a foreground run
interrupts.install()
def ctrl_c():
    os.kill(os.getpid(), signal.SIGINT)
"""

INTERRUPTS = {
    # trimesh catches BaseException in places: the next check still raises.
    "swallowed": """
try:
    ctrl_c()
except BaseException:
    pass
interrupts.check()
""",
    # Inside a file write the interrupt waits until the block is over.
    "deferred": """
done = []
with interrupts.deferred():
    ctrl_c()
    done.append(1)
""",
    # Inside a GL library's Python code, which its C code calls back into (moderngl builds its
    # uniform objects so), it is only recorded: raised there it crashed the process.
    "inside gl": """
reached = []
code = compile("ctrl_c()\\nreached.append(1)", "/site-packages/moderngl/__init__.py", "exec")
exec(code, {"ctrl_c": ctrl_c, "reached": reached})
assert reached == [1]
interrupts.check()
""",
    # Inside an import it is only recorded: raised there, it left a module half made (trimesh's
    # imports caught it, and failed later with a TypeError and a traceback).
    "inside an import": """
import pathlib, tempfile
folder = tempfile.mkdtemp()
pathlib.Path(folder, "half_made.py").write_text(
    "import __main__\\n__main__.ctrl_c()\\nfor _ in range(1000): pass\\nWHOLE = True\\n")
sys.path.insert(0, folder)
import half_made
assert half_made.WHOLE
interrupts.check()
""",
    # Recorded inside GL code, then pressed again outside it: the second is raised at once, so
    # a loop without a check still stops.
    "again after gl": """
code = compile("ctrl_c()", "/site-packages/moderngl/__init__.py", "exec")
exec(code, {"ctrl_c": ctrl_c})
ctrl_c()
print("not stopped")
""",
    # A second Ctrl-C while the first unwinds (the stats being written): recorded, not raised
    # there, where it cut the clean-up short and escaped as a traceback.
    "twice": """
from game import cli
def command(args):
    try:
        ctrl_c()
    finally:
        ctrl_c()
        print("cleaned up")
cli.COMMANDS["capture"] = command
sys.exit(cli.main(["capture"]))
""",
    # A library turned it into another exception (ctypes: ArgumentError): still exit 130.
    "converted": """
from game import cli
def command(args):
    try:
        ctrl_c()
    except KeyboardInterrupt:
        raise ValueError("argument 3: KeyboardInterrupt")
cli.COMMANDS["capture"] = command
sys.exit(cli.main(["capture"]))
""",
}


@pytest.mark.parametrize("case", sorted(INTERRUPTS))
def test_ctrl_c_is_never_lost_nor_turned_into_an_error(case):
    """Three ways a capture went wrong under Ctrl-C (150 runs stopped at random moments): it
    went on rendering, it ended as an internal error, or zipfile left a traceback."""
    code = PRELUDE + INTERRUPTS[case]
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                            text=True, timeout=60)
    if case in ("converted", "twice"):
        assert result.returncode == 130 and result.stderr.strip() == "interrupted"
        assert case != "twice" or result.stdout.strip() == "cleaned up"
    else:  # the bare snippet ends on the uncaught exception
        assert result.returncode == 1, result.stderr
        assert result.stderr.strip().splitlines()[-1] == "game.app.interrupts.Interrupted"
    assert "not stopped" not in result.stdout
    if case == "deferred":  # raised as the block ended, not inside it
        assert "in deferred" in result.stderr and "done.append" not in result.stderr
    if case in ("inside gl", "inside an import"):  # raised at the next check, not inside
        assert "in check" in result.stderr and "moderngl" not in result.stderr
        assert "half_made" not in result.stderr


def test_ctrl_c_inside_code_run_by_exec_still_exits_130(tmp_path):
    """dataclasses and namedtuples build their methods with ``exec`` of a string: a plain
    KeyboardInterrupt raised there made CPython kill the process with SIGINT at exit (-2), even
    though the command line caught it and returned 130. Only ``python -m`` runs show it."""
    (tmp_path / "stopped_in_exec.py").write_text(PRELUDE + """
from game import cli
def command(args):
    exec("ctrl_c()\\nfor _ in range(1000): pass", {"ctrl_c": ctrl_c})
cli.COMMANDS["capture"] = command
sys.exit(cli.main(["capture"]))
""")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    result = subprocess.run([sys.executable, "-m", "stopped_in_exec"], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 130, result.stderr
    assert result.stderr.strip() == "interrupted"


@pytest.mark.parametrize("delay", [0.1, 0.2, 0.3, 0.6, 1.2, 2.4])
def test_ctrl_c_during_start_up_ends_the_run_cleanly(tmp_path, delay):
    """Interrupted while the modules load (trimesh's imports lost the interrupt or failed with a
    traceback), or while the renderer compiles its programs (bench makes one renderer per run;
    a run died with SIGSEGV inside moderngl): every run must end with 0 or 130."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "game", "bench", "--quick", "--scenes", "default", "--methods",
         "clumped", "--out", str(tmp_path / "b"), "--no-progress"],
        cwd=ROOT, preexec_fn=stoppable, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode in (0, 130), err[-2000:]
    if proc.returncode == 130:
        assert err.strip().splitlines()[-1] == "interrupted"


class _FullDisk:
    """A file whose writes fail as on a full disk (or a spent quota): OSError with no file
    name, as the kernel reports them for a file descriptor."""

    def __init__(self, f, code: int):
        self.f, self.code = f, code

    def write(self, data):
        raise OSError(self.code, os.strerror(self.code))

    def __getattr__(self, name):
        return getattr(self.f, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.f.close()


@pytest.mark.parametrize("code", ["ENOSPC", "EDQUOT", "EIO"])
def test_a_failed_write_names_the_file_and_leaves_no_temp(tmp_path, monkeypatch, code):
    import errno

    number = getattr(errno, code)
    real = os.fdopen
    monkeypatch.setattr(os, "fdopen", lambda fd, mode: _FullDisk(real(fd, mode), number))
    target = tmp_path / "stats.json"
    with pytest.raises(outputs.WriteError) as caught:
        outputs.write_json(target, {"a": 1})
    message = str(caught.value)
    assert message == f"{target}: cannot write: {os.strerror(number)}"
    assert isinstance(caught.value, OSError)  # still handled as a failed write by OSError code
    assert list(tmp_path.iterdir()) == []


def test_capture_dump_into_a_full_disk_names_the_dump(capsys, tmp_path, monkeypatch):
    import errno

    from game import cli

    def full(file, *args, **kw):
        file.write(b"PK")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", full)
    out = tmp_path / "o"
    code = cli.main(["capture", str(TINY), "--size", "16x9", "--dump", "--out", str(out)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and lines == [f"error: {out / 'frame_0000.npz'}: cannot write: No space "
                                   "left on device"], lines
    assert list(out.iterdir()) == []  # no temp file, and no part of the frame
