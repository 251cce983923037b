"""Hostile input to the commands: signals, paths, pipes, terminals, dumps and bench files.

Each case is one line on standard error, the right exit status, and nothing left behind.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import threading
import time
import zipfile

import numpy as np
import pytest

from game import cli
from tests.cli.cli_helpers import expect_scene_error, run_main
from tests.cli.hostile_files import glb_with, gltf_scene, npz_declaring, one_triangle
from tests.helpers import ROOT, stoppable
from tests.helpers import TINY as TINY_PATH

TINY = TINY_PATH.read_text()


def test_verify_refuses_a_glb_that_names_any_file(capsys, tmp_path):
    dumps = tmp_path / "dumps"
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--dump", "--out",
                     str(dumps)]) == 0
    (dumps / "frame_0000.glb").write_bytes(
        glb_with({"buffers": lambda d: d["buffers"] + [{"uri": "/etc/passwd", "byteLength": 9}]}))
    code, lines = run_main(capsys, "verify", dumps)
    assert code == 1 and len(lines) == 1 and "only embedded data" in lines[0], lines


# -- decompression bombs ---------------------------------------------------------------------

def test_verify_refuses_arrays_larger_than_their_frame_before_reading_them(capsys, tmp_path):
    dumps = tmp_path / "dumps"
    dumps.mkdir()
    npz_declaring(dumps / "frame_0000.npz", {"size": np.array([16, 9])}, "position",
                  (90000, 160000, 3))
    (dumps / "frame_0000.glb").write_bytes(glb_with({}))
    code, lines = run_main(capsys, "verify", dumps, TINY_PATH)
    assert code == 1 and len(lines) == 1 and "not what a 16x9 frame holds" in lines[0], lines


@pytest.mark.parametrize("damage", ["empty", "truncated"])
def test_verify_of_a_damaged_npz_is_one_line(capsys, tmp_path, damage):
    dumps = tmp_path / "dumps"
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--dump", "--out",
                     str(dumps)]) == 0
    npz = dumps / "frame_0000.npz"
    npz.write_bytes(b"" if damage == "empty" else npz.read_bytes()[:300])
    capsys.readouterr()
    code, lines = run_main(capsys, "verify", dumps, TINY_PATH)
    assert code == 1 and len(lines) == 1 and "cannot read the dumps" in lines[0], lines


@pytest.mark.parametrize("command", ["capture", "bench"])
def test_a_scene_with_nothing_to_draw_is_one_line(capsys, tmp_path, command):
    """A camera and a light alone parse (the format asks for no object), but GL makes no
    empty buffer: that was an internal error."""
    scene = tmp_path / "empty.toml"
    scene.write_text('[camera]\nposition = [0.0, 1.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\n'
                     '[light]\nkind = "directional"\ndirection = [0.0, -1.0, 0.0]\n')
    out = tmp_path / "out"
    args = ([scene] if command == "capture" else ["--scenes", scene, "--methods", "single",
                                                  "--frames", "1", "--no-progress"])
    code, lines = run_main(capsys, command, *args, "--size", "32x18", "--out", out)
    assert code == 1 and len(lines) == 1 and "nothing to draw" in lines[0], lines
    assert not out.exists() or command == "bench"  # bench keeps a failed run as a row


# -- sizes past the limits -------------------------------------------------------------------

def test_a_generated_town_past_the_triangle_limit_is_refused_at_once(capsys, tmp_path):
    text = TINY + "\n[generate]\nblocks = 64\nbuildings_per_block = 64\nmax_storeys = 100\n" \
                  "detail = 5\nblock_size = 1000.0\n"
    start = time.perf_counter()
    expect_scene_error(capsys, tmp_path, text, None, "generate.blocks", "triangles")
    assert time.perf_counter() - start < 5  # estimated, not built


def test_a_scene_file_that_is_not_a_regular_file_or_too_large(capsys, tmp_path):
    code, lines = run_main(capsys, "capture", "/dev/zero", "--out", tmp_path / "o")
    assert code == 1 and lines == ["error: /dev/zero: not a regular file (a device or socket)"]
    big = tmp_path / "big.toml"
    big.write_text(TINY + "#" * (5 * 2**20))
    code, lines = run_main(capsys, "capture", big, "--out", tmp_path / "o")
    assert code == 1 and len(lines) == 1 and "MiB a scene file may be" in lines[0]


@pytest.mark.parametrize("flag, value", [("--vc-pool", "1000000000"),
                                         ("--mailbox", "1000000000"),
                                         ("--vc-slots", str(2**40)),
                                         ("--samples", "100000000"),
                                         ("--cells-per-triangle", "1e9")])
def test_tracer_parameters_are_bounded_before_any_allocation(capsys, tmp_path, flag, value):
    code, lines = run_main(capsys, "trace", TINY_PATH, flag, value, "--out", tmp_path / "o")
    assert code == 2 and len(lines) == 1 and flag in lines[0] and "at most" in lines[0]
    assert not (tmp_path / "o").exists()


def test_a_frame_too_large_for_the_gl_is_one_line(capsys, tmp_path):
    code, lines = run_main(capsys, "capture", TINY_PATH, "--size", "16384x16384", "--dump",
                           "--out", tmp_path / "o")
    assert code == 1 and len(lines) == 1 and "GiB" in lines[0], lines


@pytest.mark.parametrize("args", [["--time", "1e308"], ["--fps", "1e-308"],
                                  ["--frames", "1000000000000", "--fps", "0.001"]])
def test_scene_times_past_their_range(capsys, tmp_path, args):
    code, lines = run_main(capsys, "capture", TINY_PATH, *args, "--out", tmp_path / "o")
    assert code == 2 and len(lines) == 1, lines


# -- magnitudes ------------------------------------------------------------------------------

@pytest.mark.parametrize("old, new, key", [
    ("radius   = 0.7", "radius   = 0.7\nscale    = 1e300", "static[1].scale"),
    ("position = [0.0, 6.0, 10.0]", "position = [1e300, 6.0, 10.0]", "camera.position"),
    ("fov      = 60.0", "fov      = 60.0\nnear     = 1e-9", "camera.near"),
    ("speed  = 1.5", "speed  = 1e308", "character[0].speed"),
    ("speed  = 1.5", "speed  = " + "9" * 400, "character[0].speed"),
    ("position = [1.5, 0.7, 0.8]", "position = [9e5, 0.7, 0.8]\nscale    = 5e5",
     "static[1].scale"),
    # Collapsed to a point: NaN normals, and a numpy warning on the way.
    ("radius   = 0.7", "radius   = 1e-300", "static[1].radius"),
    ("size     = [1.5, 2.0, 1.0]", "size     = [1.5, 1e-300, 1.0]", "static[0].size"),
    ("radius   = 0.7", "radius   = 0.7\nscale    = 1e-300", "static[1].scale"),
])
def test_magnitudes_that_cannot_render_are_refused_in_one_line(capsys, tmp_path, old, new, key):
    assert old in TINY
    expect_scene_error(capsys, tmp_path, TINY.replace(old, new, 1), None, key)


def test_a_toml_integer_too_long_to_read_is_one_line(capsys, tmp_path):
    """Python refuses integers of more than 4,300 digits: that was an internal error."""
    expect_scene_error(capsys, tmp_path, TINY.replace("speed  = 1.5", "speed  = " + "9" * 5000,
                                                      1), None, "too long to read")


def test_deeply_nested_toml_is_one_line(capsys, tmp_path):
    expect_scene_error(capsys, tmp_path, TINY + "x = " + "[" * 20000 + "]" * 20000 + "\n",
                       None, "")


def test_a_frame_path_that_is_a_folder(capsys, tmp_path):
    (tmp_path / "o" / "frame_0000.png").mkdir(parents=True)
    code, lines = run_main(capsys, "capture", TINY_PATH, "--size", "16x9", "--out", tmp_path / "o")
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith("error: ") and "frame_0000.png" in lines[0], lines


# -- special files, temp files, signals ------------------------------------------------------

def test_stats_to_a_device_or_a_pipe_are_written_to_and_never_replaced(tmp_path):
    # A device node of its own (never /dev/null itself: code with the bug would replace it).
    device = tmp_path / "null"
    try:
        os.mknod(device, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, OSError):
        device = None  # no CAP_MKNOD here: the pipe still checks the rule
    if device is not None:
        assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--out",
                         str(tmp_path / "o"), "--stats", str(device)]) == 0
        assert device.is_char_device()
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    received = []
    reader = threading.Thread(target=lambda: received.append(pipe.read_bytes()))
    reader.start()
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--out", str(tmp_path / "o"),
                     "--stats", str(pipe)]) == 0
    reader.join(timeout=60)
    assert pipe.is_fifo() and json.loads(received[0])["frames"]


def test_stale_temp_files_of_dead_runs_are_removed_and_only_those(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    dead = out / ".frame_0003.npz.999999999.0123abcd.tmp"   # no process has this pid
    alive = out / f".frame_0004.npz.{os.getpid()}.0123abcd.tmp"
    other = out / ".notes.tmp"
    for path in (dead, alive, other):
        path.write_bytes(b"x")
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--out", str(out)]) == 0
    assert not dead.exists() and alive.exists() and other.exists()


@pytest.mark.parametrize("sig, status, line", [(signal.SIGTERM, 143, "terminated by SIGTERM"),
                                               (signal.SIGHUP, 129, "terminated by SIGHUP")])
def test_sigterm_and_sighup_end_a_run_like_ctrl_c(tmp_path, sig, status, line):
    out, stats = tmp_path / "out", tmp_path / "stats.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "game", "capture", str(TINY_PATH), "--size", "48x27", "--frames",
         "100000", "--dump", "--out", str(out), "--stats", str(stats)],
        cwd=ROOT, preexec_fn=stoppable, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while len(list(out.glob("frame_*.glb"))) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.02)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == status and err.strip().splitlines() == [line]
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]
    document = json.loads(stats.read_text())
    assert document["interrupted"] is True
    assert len(document["frames"]) == len(list(out.glob("frame_*.glb")))


def test_trace_stats_record_memory_and_gl_objects(tmp_path):
    stats = tmp_path / "s.json"
    assert cli.main(["trace", str(TINY_PATH), "--size", "16x9", "--samples", "1", "--frames",
                     "3", "--out", str(tmp_path / "o"), "--stats", str(stats)]) == 0
    frames = json.loads(stats.read_text())["frames"]
    assert all(f["rss_mib"] > 0 and f["gl_objects"] > 0 for f in frames)
    assert len({f["gl_objects"] for f in frames[1:]}) == 1


# -- control characters ----------------------------------------------------------------------

@pytest.mark.parametrize("name", ["a\nb.toml", "error: all good\r.toml", "\x1b]0;owned\x07.toml",
                                  "\x1b[2J.toml"])
def test_control_characters_never_reach_the_terminal(capsys, tmp_path, name):
    code, lines = run_main(capsys, "capture", tmp_path / name, "--out", tmp_path / "o")
    assert code == 1 and len(lines) == 1
    assert not any(ch in lines[0] for ch in "\n\r\x1b\x07"), lines[0]


def test_a_key_with_an_escape_sequence_is_escaped(capsys, tmp_path):
    text = TINY.replace("fov      = 60.0", 'fov      = 60.0\n"\\u001b[2Jevil" = 1')
    message = expect_scene_error(capsys, tmp_path, text, None, "camera.")
    assert "\x1b" not in message and "\\x1b" in message


# -- more bombs and damaged files ------------------------------------------------------------

def test_a_full_disk_is_one_line_and_leaves_no_temp_file(capsys, tmp_path, monkeypatch):
    import errno

    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device", str(dst))

    monkeypatch.setattr(os, "replace", full)
    code, lines = run_main(capsys, "capture", TINY_PATH, "--size", "16x9", "--out", tmp_path / "o")
    assert code == 1 and len(lines) == 1 and "No space left on device" in lines[0], lines
    assert lines[0].startswith("error: ")
    assert not list((tmp_path / "o").iterdir())


def test_a_damaged_bench_csv_is_refused_and_a_cut_row_is_measured_again(capsys, tmp_path):
    from game.bench.rows import read_rows
    from game.bench.runs import COLUMNS

    out = tmp_path / "b"
    out.mkdir()
    (out / "bench.csv").write_text("a,b\n1,2\n")
    code, lines = run_main(capsys, "bench", "--out", out, "--scenes", "default", "--methods",
                           "single", "--no-progress")
    assert code == 1 and len(lines) == 1 and "not a bench CSV" in lines[0], lines
    whole = dict.fromkeys(COLUMNS, "1")
    whole.update(run="default|single|defaults|320x180", status="ok")
    header = ",".join(COLUMNS)
    (out / "bench.csv").write_text(header + "\n" + ",".join(whole[c] for c in COLUMNS) + "\n"
                                   + "default|csm|defaults|320x180,default,main\n")
    assert [r["run"] for r in read_rows(out / "bench.csv")] == ["default|single|defaults|320x180"]


def test_verify_refuses_dumps_declaring_more_than_a_dump_may_hold(capsys, tmp_path):
    dumps = tmp_path / "dumps"
    dumps.mkdir()
    with zipfile.ZipFile(dumps / "frame_0000.npz", "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("size.npy", "w") as f:
            np.lib.format.write_array(f, np.array([16384, 16384]))
        for key in ("position", "normal"):
            with z.open(f"{key}.npy", "w") as f:
                np.lib.format.write_array_header_1_0(
                    f, {"descr": "<f4", "fortran_order": False, "shape": (16384, 16384, 3)})
    (dumps / "frame_0000.glb").write_bytes(glb_with({}))
    code, lines = run_main(capsys, "verify", dumps, TINY_PATH)
    assert code == 1 and len(lines) == 1 and "a dump may hold" in lines[0], lines


def test_stats_to_a_pipe_nobody_reads_is_one_line_not_a_hang(tmp_path):
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    result = subprocess.run([sys.executable, "-m", "game", "capture", str(TINY_PATH), "--size",
                             "16x9", "--out", str(tmp_path / "o"), "--stats", str(pipe)],
                            cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines() == [f"error: {pipe}: a pipe with no reader"]


def test_a_new_run_in_the_same_process_starts_with_no_interrupt_pending(capsys, tmp_path):
    from game.app import interrupts

    # An earlier run in this process, stopped with SIGTERM, leaves its interrupt pending.
    interrupts.install()
    if not callable(signal.getsignal(signal.SIGTERM)):
        pytest.skip("SIGTERM is ignored here, so no run can be stopped with it")
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGTERM)
    assert interrupts.pending()
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--out",
                     str(tmp_path / "o")]) == 0


def test_library_log_lines_are_escaped_warnings(capsys, tmp_path):
    import logging

    cli.main(["capture", "/nowhere.toml"])  # installs the handler
    capsys.readouterr()
    logging.getLogger("trimesh").warning("EVIL\n\x1b[31mRED\x1b[0m")
    err = capsys.readouterr().err
    assert err == "warning: EVIL \\x1b[31mRED\\x1b[0m\n"


@pytest.mark.parametrize("sig, status, line", [(signal.SIGTERM, 143, "terminated by SIGTERM"),
                                               (signal.SIGHUP, 129, "terminated by SIGHUP")])
def test_sigterm_while_the_modules_load_is_the_same_one_line(sig, status, line):
    proc = subprocess.Popen([sys.executable, "-m", "game", "capture", "--help"], cwd=ROOT,
                            preexec_fn=stoppable, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(0.1)  # python -m game is still importing numpy, trimesh, moderngl
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    if proc.returncode != 0:  # 0: it had finished already on a fast machine
        assert proc.returncode == status and err.strip().splitlines() == [line], err


# -- files a glTF names, node trees, instancing, OBJ groups and crowds -----------------------

def test_float_indices_are_named(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    document["accessors"][1]["componentType"] = 5126
    expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", document, binary), None,
                       "static[2].file", "indices", "unsigned")


def test_hand_written_characters_past_the_limit_are_refused_at_once(capsys, tmp_path):
    from game.scene.loader import MAX_CHARACTERS

    walker = ('\n[[character]]\nshape = "capsule"\nradius = 0.3\nheight = 1.8\n'
              'path = [[-3.0, 0.9, -3.0], [3.0, 0.9, -3.0]]\n')
    start = time.perf_counter()
    expect_scene_error(capsys, tmp_path, TINY + walker * MAX_CHARACTERS, None,
                       f"character[{MAX_CHARACTERS}]", f"at most {MAX_CHARACTERS:,} characters")
    assert time.perf_counter() - start < 10


