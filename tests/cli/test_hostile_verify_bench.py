"""Hostile input to ``verify`` and ``bench``: a dump that names a file outside every scene folder,
dump arrays of the wrong type, failed bench runs, signals, and output paths that are folders or
pipes. Each case ends in one line on standard error and a non-zero exit, and reads nothing the
user did not name."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from game import cli
from tests.cli.cli_helpers import assert_one_line_error, run, run_main
from tests.helpers import PLAZA, ROOT, stoppable
from tests.helpers import TINY as TINY_PATH

pytest.importorskip("matplotlib", reason="bench charts need matplotlib (pip install .[bench])")
pytest.importorskip("tqdm", reason="bench needs tqdm (pip install .[bench])")

# A bench of the tiny scene that measures as little as it can.
BENCH = ["--scenes", str(TINY_PATH), "--size", "32x18", "--frames", "1", "--warmup", "0",
         "--error-frames", "0", "--flicker-frames", "0"]


@pytest.fixture(scope="module")
def tiny_dumps(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("dumps") / "d"
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--dump", "--out",
                     str(folder)]) == 0
    return folder


def rewritten(tiny_dumps: Path, tmp_path: Path, **arrays) -> Path:
    """A copy of the dumps with ``arrays`` replacing (or adding to) the frame's own."""
    folder = tmp_path / "dumps"
    shutil.copytree(tiny_dumps, folder)
    npz = folder / "frame_0000.npz"
    with np.load(npz) as data:
        stored = {key: data[key] for key in data.files}
    stored.update(arrays)
    np.savez(npz, **stored)
    return folder


# -- verify: the recorded scene --------------------------------------------------------------

@pytest.mark.parametrize("target", ["/etc/passwd", "/dev/zero", "fifo", "big"])
def test_verify_parses_no_recorded_file_whose_hash_differs(capsys, tmp_path, tiny_dumps,
                                                           monkeypatch, target):
    from game.scene import loader

    if target == "fifo":
        target = str(tmp_path / "pipe.toml")
        os.mkfifo(target)
    elif target == "big":  # past a scene file's size: not even hashed
        target = str(tmp_path / "big.toml")
        Path(target).write_bytes(b"#" * (loader.MAX_SCENE_BYTES + 1))
    parsed = []
    real_parse = loader.parse_scene

    def spy(text, source=None, **kw):
        parsed.append(str(source))
        return real_parse(text, source=source, **kw)

    monkeypatch.setattr(loader, "parse_scene", spy)
    folder = rewritten(tiny_dumps, tmp_path, scene=np.array(target),
                       scene_path=np.array(target))
    code, lines = run_main(capsys, "verify", folder)
    assert code == 1 and len(lines) == 1, lines
    assert "does not match" in lines[0] and "SCENE" in lines[0], lines[0]
    assert "TOML" not in lines[0], lines[0]
    assert parsed == []


def test_verify_still_finds_a_recorded_scene_with_the_recorded_hash(capsys, tmp_path,
                                                                     tiny_dumps):
    pytest.importorskip("embreex")
    copy = tmp_path / "elsewhere" / "mine.toml"
    copy.parent.mkdir()
    shutil.copy(TINY_PATH, copy)
    folder = rewritten(tiny_dumps, tmp_path, scene=np.array("gone.toml"),
                       scene_path=np.array(str(copy)))
    code, lines = run_main(capsys, "verify", folder)
    assert code == 0, lines


# -- verify: the arrays' types and shapes ----------------------------------------------------

WRONG_ARRAYS = {
    "lit datetime64": ("lit", np.zeros((9, 16), "datetime64[s]")),
    "lit unicode": ("lit", np.full((9, 16), "x")),
    "lit bool": ("lit", np.zeros((9, 16), bool)),
    "lit_lights unicode": ("lit_lights", np.full((9, 16, 1), "x")),
    "position complex": ("position", np.zeros((9, 16, 3), np.complex64)),
    "normal int": ("normal", np.zeros((9, 16, 3), np.int32)),
    "object float": ("object", np.zeros((9, 16), np.float32)),
    "view 3x3": ("view", np.eye(3)),
    "proj unicode": ("proj", np.full((4, 4), "p")),
    "time a vector": ("time", np.zeros(3)),
    "names numbers": ("names", np.arange(3)),
    "scene_sha256 bytes": ("scene_sha256", np.array(b"ab")),
}


@pytest.mark.parametrize("case", sorted(WRONG_ARRAYS))
def test_verify_names_an_array_of_the_wrong_type_or_shape(capsys, tmp_path, tiny_dumps, case):
    key, value = WRONG_ARRAYS[case]
    folder = rewritten(tiny_dumps, tmp_path, **{key: value})
    code, lines = run_main(capsys, "verify", folder, TINY_PATH)
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith("error: ") and f"'{key}'" in lines[0], lines[0]
    assert "frame_0000.npz" in lines[0], lines[0]


def test_verify_names_a_missing_array(capsys, tmp_path, tiny_dumps):
    folder = rewritten(tiny_dumps, tmp_path)
    npz = folder / "frame_0000.npz"
    with np.load(npz) as data:
        kept = {key: data[key] for key in data.files if key != "normal"}
    np.savez(npz, **kept)
    code, lines = run_main(capsys, "verify", folder, TINY_PATH)
    assert code == 1 and len(lines) == 1 and "'normal'" in lines[0], lines


# -- bench: failed runs ----------------------------------------------------------------------

def test_a_failed_bench_run_fails_the_bench_after_the_others(capsys, tmp_path, monkeypatch):
    from game.bench import measure

    real = measure.measure_timing

    def fail_clumped(ctx, scene, spec, opts):  # the first run the bench plans
        if spec.method == "clumped":
            raise ValueError("made to fail\nsecond line")
        return real(ctx, scene, spec, opts)

    monkeypatch.setattr(measure, "measure_timing", fail_clumped)
    out = tmp_path / "b"
    code, lines = run_main(capsys, "bench", *BENCH, "--methods", "single,clumped", "--out", out,
                           "--no-progress")
    assert code == 1
    assert len(lines) == 1, lines
    assert "1 of 2 runs failed" in lines[0] and "tiny|clumped" in lines[0], lines[0]
    assert "made to fail" in lines[0] and "second line" not in lines[0], lines[0]
    rows = (out / "bench.csv").read_text().splitlines()
    assert len(rows) == 3 and "failed: ValueError" in rows[1]
    assert rows[2].startswith("tiny|single") and ",ok," in rows[2]  # made after the failure
    assert (out / "summary.json").is_file()
    # Kept in bench.csv, the failure is reported again by a rerun that measures nothing.
    code, lines = run_main(capsys, "bench", *BENCH, "--methods", "single,clumped", "--out", out,
                           "--no-progress")
    assert code == 1 and len(lines) == 1 and "1 of 2 runs failed" in lines[0], lines


@pytest.mark.parametrize(("make", "said"), [("fifo", "FIFO"),
                                            ("link out", "out of the dump folder"),
                                            ("link loop", "cannot follow")])
def test_verify_reads_only_the_dump_folders_own_regular_files(capsys, tmp_path, make, said):
    """A FIFO named like a dump blocked verify for good; a link named like one was read
    wherever it pointed."""
    folder = tmp_path / "dumps"
    folder.mkdir()
    outside = tmp_path / "elsewhere.npz"
    outside.write_bytes(b"not a dump")
    dump = folder / "frame_0000.npz"
    if make == "fifo":
        os.mkfifo(dump)
    elif make == "link out":
        dump.symlink_to(outside)
    else:
        (folder / "loop").symlink_to(dump)
        dump.symlink_to(folder / "loop")
    code, lines = run_main(capsys, "verify", folder)
    assert code == 1 and len(lines) == 1 and "frame_0000.npz" in lines[0], lines
    assert said in lines[0], lines


def test_verify_refuses_a_geometry_file_of_another_scene(capsys, tmp_path):
    """Beside another scene's geometry the frame scored a confident wrong error, exit 0."""
    for name in ("tiny", "other"):
        code, _ = run_main(capsys, "capture", TINY_PATH if name == "tiny" else PLAZA, "--size",
                           "64x36", "--frames", "1", "--dump", "--out", tmp_path / name)
        assert code == 0
    shutil.copy(tmp_path / "tiny" / "frame_0000.glb", tmp_path / "other" / "frame_0000.glb")
    code, lines = run_main(capsys, "verify", tmp_path / "other")
    assert code == 1 and len(lines) == 1 and "do not lie on the geometry" in lines[0], lines


# -- bench: signals --------------------------------------------------------------------------

@pytest.mark.parametrize("sig, status, line", [(signal.SIGINT, 130, "interrupted"),
                                               (signal.SIGTERM, 143, "terminated by SIGTERM")])
def test_an_interrupted_bench_prints_one_line(tmp_path, sig, status, line):
    out = tmp_path / "b"
    args = [*BENCH, "--frames", "30", "--methods", "clumped,single,csm,static-dynamic"]
    proc = subprocess.Popen([sys.executable, "-m", "game", "bench", *args, "--out", str(out)],
                            cwd=ROOT, preexec_fn=stoppable, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (out / "bench.csv").exists():  # the first run is done: the bar has started
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == status and err.strip().splitlines() == [line], repr(err)


def test_a_bench_repeating_its_runs_stops_at_ctrl_c(tmp_path):
    """The repetitions' frames are drawn in turns, inside GL code, where a signal is only
    recorded: the loop must raise it at its next frame, not run every repetition first."""
    out = tmp_path / "b"
    proc = subprocess.Popen([sys.executable, "-m", "game", "bench", *BENCH, "--methods", "single",
                             "--repeat", "100000", "--no-progress", "--out", str(out)],
                            cwd=ROOT, preexec_fn=stoppable, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (out / "run.json").exists():  # the runs have started
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    time.sleep(2.0)  # into the repetitions
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130 and err.strip().splitlines() == ["interrupted"], repr(err)


# -- bench: output paths, checked before any work --------------------------------------------

def _folder(path: Path) -> None:
    path.mkdir(parents=True)


def _file(path: Path) -> None:
    path.write_text("a file where a folder goes")


OUTPUT_PATHS = {
    "bench.csv a folder": ("bench.csv", _folder),
    "summary.json a folder": ("summary.json", _folder),
    "summary.json a fifo": ("summary.json", os.mkfifo),
    "run.json a folder": ("run.json", _folder),
    "charts a file": ("charts", _file),
    "a chart a folder": ("charts/pareto_tiny.png", _folder),
    "scenes a file": ("scenes", _file),
}


@pytest.mark.parametrize("case", sorted(OUTPUT_PATHS))
def test_bench_checks_its_output_paths_before_any_run(capsys, tmp_path, monkeypatch, case):
    from game.gpu import context

    def no_gl(*args, **kw):
        raise AssertionError("GL work before the output paths were checked")

    monkeypatch.setattr(context, "create_headless", no_gl)
    name, make = OUTPUT_PATHS[case]
    out = tmp_path / "b"
    out.mkdir()
    (out / name).parent.mkdir(parents=True, exist_ok=True)
    make(out / name)
    code, lines = run_main(capsys, "bench", *BENCH, "--methods", "single", "--out", out,
                           "--no-progress")
    assert code != 0 and len(lines) == 1, lines
    assert lines[0].startswith("error: ") and name in lines[0], lines[0]


def test_a_bench_csv_that_is_a_pipe_is_refused_not_read(tmp_path):
    out = tmp_path / "b"
    out.mkdir()
    os.mkfifo(out / "bench.csv")
    result = subprocess.run([sys.executable, "-m", "game", "bench", *BENCH, "--methods",
                             "single", "--out", str(out), "--no-progress"], cwd=ROOT,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "bench.csv" in lines[0] and "not a regular file" in lines[0], \
        lines


def test_a_bench_csv_swapped_for_a_pipe_after_the_first_check_is_still_not_read(
        capsys, tmp_path, monkeypatch):
    from game.bench import runner
    from game.gpu import context

    def no_gl(*args, **kw):
        raise AssertionError("GL work before bench.csv was read")

    out = tmp_path / "b"
    # Were the pipe opened to read, this writer would let the read end, empty, not hang.
    writer = threading.Timer(10.0, lambda: os.close(os.open(out / "bench.csv", os.O_WRONLY)))
    writer.daemon = True
    real_clean = runner.clean

    def swap(folder):   # between the up-front check of the outputs and the read to resume
        real_clean(folder)
        os.mkfifo(folder / "bench.csv")
        writer.start()

    monkeypatch.setattr(context, "create_headless", no_gl)
    monkeypatch.setattr(runner, "clean", swap)
    try:
        code, lines = run_main(capsys, "bench", *BENCH, "--methods", "single", "--out", out,
                               "--no-progress")
    finally:
        writer.cancel()
    assert code == 1 and lines == [f"error: {out / 'bench.csv'}: not a regular file (a FIFO)"]


@pytest.mark.parametrize("name", ["summary.md", "summary.json", "window.json"])
def test_the_gpu_suite_checks_its_output_paths_first(capsys, tmp_path, monkeypatch, name):
    from game.gpu import context

    def no_gl(*args, **kw):
        raise AssertionError("GL work before the output paths were checked")

    monkeypatch.setattr(context, "create_headless", no_gl)
    out = tmp_path / "g"
    (out / name).mkdir(parents=True)
    code, lines = run_main(capsys, "bench", "--suite", "gpu", "--quick", "--out", out,
                           "--no-progress")
    assert code != 0 and len(lines) == 1, lines
    assert name in lines[0], lines[0]


def test_a_bench_without_its_extras_says_so_and_writes_nothing(tmp_path):
    # tqdm hidden behind a module of the same name that will not import.
    hide = tmp_path / "hide"
    hide.mkdir()
    (hide / "tqdm.py").write_text('raise ImportError("hidden by the test")\n')
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(hide), str(ROOT)])}
    out = tmp_path / "out"
    result = run("bench", *BENCH, "--out", out, env=env)
    assert_one_line_error(result, "bench needs tqdm and matplotlib", "pip install -e '.[bench]'")
    assert not out.exists()
