"""Hostile input: files that point outside the scene's folder, decompression bombs, sizes and
magnitudes past every limit, signals, special files and control characters.

Each case gets one clear line and a non-zero exit; nothing outside the scene's folder is read;
no file is left partial or as a temp file; memory stays bounded. Big cases are made small but
still over the limits. docs/reliability.md lists the limits.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import struct
import subprocess
import sys
import threading
import time
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest
import trimesh

from game import cli, gltf
from game.scene.mesh_files import binary_stl_damage
from tests.cli.cli_helpers import MESH, expect_scene_error, run_main
from tests.helpers import ROOT, stoppable
from tests.helpers import TINY as TINY_PATH

TINY = TINY_PATH.read_text()


def glb_with(document_extra: dict, binary: bytes = b"") -> bytes:
    """A GLB holding one triangle, plus ``document_extra`` merged into its JSON."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    indices = np.array([0, 1, 2], np.uint32).tobytes()
    data = positions + indices
    document = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
        "buffers": [{"byteLength": len(data)}],
    }
    for key, value in document_extra.items():
        document[key] = value(document) if callable(value) else value
    return gltf.join_glb(document, data + binary)


def big_png(side: int) -> bytes:
    """A ``side`` x ``side`` black PNG, compressed row by row (never whole in memory)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    packer = zlib.compressobj(9)
    row = b"\0" * (1 + side)
    body = b"".join(packer.compress(row) for _ in range(side)) + packer.flush()
    header = struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", body)
            + chunk(b"IEND", b""))


def mesh_scene(folder: Path, name: str) -> str:
    return TINY + MESH.format(file=name)


# -- files outside the scene's folder --------------------------------------------------------

@pytest.mark.parametrize("uri", ["/etc/passwd", "../secret.bin", "file:///etc/passwd",
                                 "sub/../../secret.bin"])
@pytest.mark.parametrize("section", ["buffers", "images"])
def test_a_glb_naming_an_outside_file_is_refused_before_trimesh_reads_it(
        capsys, tmp_path, monkeypatch, uri, section):
    folder = tmp_path / "scene"
    folder.mkdir()
    (tmp_path / "secret.bin").write_bytes(b"\0" * 64)
    extra = ({"buffers": lambda d: d["buffers"] + [{"uri": uri, "byteLength": 64}]}
             if section == "buffers" else {"images": [{"uri": uri}]})
    (folder / "level.glb").write_bytes(glb_with(extra))
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got the file"))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "URI")


def test_a_gltf_naming_an_outside_buffer_is_refused(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "level.gltf").write_text(json.dumps(
        {"asset": {"version": "2.0"}, "buffers": [{"uri": "../../x.bin", "byteLength": 4}]}))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.gltf"), None, "static[2].file",
                       "leaves the scene's folder")


def test_verify_refuses_a_glb_that_names_any_file(capsys, tmp_path):
    dumps = tmp_path / "dumps"
    assert cli.main(["capture", str(TINY_PATH), "--size", "16x9", "--dump", "--out",
                     str(dumps)]) == 0
    (dumps / "frame_0000.glb").write_bytes(
        glb_with({"buffers": lambda d: d["buffers"] + [{"uri": "/etc/passwd", "byteLength": 9}]}))
    code, lines = run_main(capsys, "verify", dumps)
    assert code == 1 and len(lines) == 1 and "only embedded data" in lines[0], lines


# -- decompression bombs ---------------------------------------------------------------------

def test_glb_textures_are_never_decoded(capsys, tmp_path, monkeypatch):
    folder = tmp_path / "scene"
    folder.mkdir()
    png = big_png(6000)  # 36 MB of pixels in a few tens of kilobytes
    view = {"buffer": 0, "byteOffset": 48, "byteLength": len(png)}
    extra = {"bufferViews": lambda d: d["bufferViews"] + [view],
             "buffers": [{"byteLength": 48 + len(png)}],
             "images": [{"bufferView": 2, "mimeType": "image/png"}] * 4,
             "textures": [{"source": 0}], "materials": [
                 {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
             "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                         "material": 0}]}]}
    (folder / "level.glb").write_bytes(glb_with(extra, png))
    import PIL.Image

    decoded = []  # recorded, not raised: trimesh swallows exceptions around image loading
    real_open = PIL.Image.open
    monkeypatch.setattr(PIL.Image, "open", lambda *a, **k: decoded.append(1) or real_open(*a, **k))
    scene = folder / "s.toml"
    scene.write_text(mesh_scene(folder, "level.glb"))
    code, lines = run_main(capsys, "capture", scene, "--size", "16x9", "--out", tmp_path / "o")
    assert code == 0, lines
    assert not decoded


def npz_declaring(path: Path, arrays: dict[str, np.ndarray], huge: str, shape: tuple) -> None:
    """An npz of ``arrays`` plus member ``huge`` whose header declares ``shape`` of float32 but
    holds a few bytes: np.load would allocate the declared size."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for key, value in arrays.items():
            with z.open(f"{key}.npy", "w") as f:
                np.lib.format.write_array(f, value)
        header = {"descr": "<f4", "fortran_order": False, "shape": shape}
        with z.open(f"{huge}.npy", "w") as f:
            np.lib.format.write_array_header_1_0(f, header)
            f.write(b"\0" * 64)


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


# -- sizes past the limits -------------------------------------------------------------------

def test_a_generated_town_past_the_triangle_limit_is_refused_at_once(capsys, tmp_path):
    text = TINY + "\n[generate]\nblocks = 64\nbuildings_per_block = 64\nmax_storeys = 100\n" \
                  "detail = 5\nblock_size = 1000.0\n"
    start = time.perf_counter()
    expect_scene_error(capsys, tmp_path, text, None, "generate.blocks", "triangles")
    assert time.perf_counter() - start < 5  # estimated, not built


def test_a_scene_file_that_is_not_a_regular_file_or_too_large(capsys, tmp_path):
    code, lines = run_main(capsys, "capture", "/dev/zero", "--out", tmp_path / "o")
    assert code == 1 and lines == ["error: /dev/zero: not a regular file (a scene is a TOML "
                                   "file)"]
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
])
def test_magnitudes_that_cannot_render_are_refused_in_one_line(capsys, tmp_path, old, new, key):
    assert old in TINY
    expect_scene_error(capsys, tmp_path, TINY.replace(old, new, 1), None, key)


def test_mesh_coordinates_past_float32_are_refused(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "far.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e39 0 0\nv 0 1e30 0\n"
                                    "v 0 0 1\nf 1 2 3\nf 4 5 6\n")
    expect_scene_error(capsys, folder, mesh_scene(folder, "far.obj"), None, "static[2].file",
                       "at most 1e+09")


def test_a_small_triangle_beside_a_large_one_is_kept(tmp_path):
    from game.scene import load_scene

    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "mixed.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e8 0 0\nv 0 1e8 0\n"
                                      "v 0 0 1e8\nf 1 2 3\nf 4 5 6\n")
    (folder / "s.toml").write_text(mesh_scene(folder, "mixed.obj").replace(
        'file = "mixed.obj"', 'file = "mixed.obj"\nscale = 1e-3'))
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == 2


# -- paths -----------------------------------------------------------------------------------

@pytest.mark.parametrize("name, fragment", [("a\\u0000b.obj", "NUL"), ("x" * 300 + ".obj",
                                                                        "255 bytes"),
                                            ("loop.obj", "cannot follow")])
def test_odd_mesh_paths(capsys, tmp_path, name, fragment):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "loop.obj").symlink_to(folder / "loop.obj")
    expect_scene_error(capsys, folder, mesh_scene(folder, name), None, "static[2].file", fragment)


def test_deeply_nested_toml_is_one_line(capsys, tmp_path):
    expect_scene_error(capsys, tmp_path, TINY + "x = " + "[" * 20000 + "]" * 20000 + "\n",
                       None, "")


def test_a_truncated_binary_stl_names_the_damage(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    data = trimesh.creation.box().export(file_type="stl")
    (folder / "cut.stl").write_bytes(data[:200])
    message = expect_scene_error(capsys, folder, mesh_scene(folder, "cut.stl"), None,
                                 "static[2].file", "cannot read mesh",
                                 "truncated binary STL", "says 12 triangles, 684 bytes")
    assert "module" not in message


def test_stl_damage_is_judged_from_the_header_and_the_size():
    """The same answer whatever optional modules trimesh finds (it reads a binary STL of the
    wrong size as text, and reported it differently on two machines)."""
    whole = trimesh.creation.box().export(file_type="stl")
    text = trimesh.creation.box().export(file_type="stl_ascii").encode()
    assert binary_stl_damage(whole[:84], len(whole)) is None
    assert binary_stl_damage(text[:84], len(text)) is None
    assert "shorter than its header" in binary_stl_damage(whole[:40], 40)
    assert "the file has 700" in binary_stl_damage(whole[:84], 700)  # padded after the triangles


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

def test_a_glb_accessor_declaring_more_than_its_buffer_holds(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    huge = {"accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 10**9, "type": "VEC3"},
        {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}]}
    (folder / "level.glb").write_bytes(glb_with(huge))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "1,000,000,000 elements")


def test_a_glb_whose_json_nests_too_deep(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    deep: dict = {}
    for _ in range(200):
        deep = {"x": deep}
    (folder / "level.glb").write_bytes(glb_with({"extras": deep}))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "nests deeper")


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


def test_a_glb_accessor_without_data_declaring_millions_of_elements(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    zeros = {"accessors": [{"componentType": 5126, "count": 4 * 10**8, "type": "VEC3"},
                           {"bufferView": 1, "componentType": 5125, "count": 3,
                            "type": "SCALAR"}]}
    (folder / "level.glb").write_bytes(glb_with(zeros))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "without data declares 400,000,000 elements")


@pytest.mark.parametrize("extra", [{"accessors": 5},
                                   {"bufferViews": [{"buffer": 0, "byteLength": 36,
                                                     "byteStride": "a"},
                                                    {"buffer": 0, "byteOffset": 36,
                                                     "byteLength": 12}]},
                                   {"meshes": [{"primitives": 7}]}])
def test_glb_fields_of_the_wrong_type_are_one_line(capsys, tmp_path, extra):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "level.glb").write_bytes(glb_with(extra))
    message = expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None,
                                 "static[2].file", "cannot read mesh level.glb")
    assert "internal error" not in message


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

def gltf_scene(folder: Path, name: str, document: dict, binary: bytes = b"") -> str:
    """Write ``document`` (with ``binary`` for a GLB) as ``name`` inside ``folder``."""
    target = folder / name
    target.parent.mkdir(parents=True, exist_ok=True)
    if name.endswith(".glb"):
        target.write_bytes(gltf.join_glb(document, binary))
    else:
        target.write_text(json.dumps(document))
    return mesh_scene(folder, name)


def one_triangle() -> tuple[dict, bytes]:
    """The document and binary data of :func:`glb_with` without extras."""
    document, binary = gltf.split_glb(glb_with({}))
    return document, binary


@pytest.mark.parametrize("special", ["fifo", "folder"])
def test_a_gltf_buffer_that_is_not_a_regular_file_is_refused_not_opened(tmp_path, special):
    folder = tmp_path / "scene"
    folder.mkdir()
    if special == "fifo":
        os.mkfifo(folder / "m.bin")  # opening it for reading would wait for a writer for good
    else:
        (folder / "m.bin").mkdir()
    document, _ = one_triangle()
    document["buffers"] = [{"uri": "m.bin", "byteLength": 48}]
    (folder / "s.toml").write_text(gltf_scene(folder, "m.gltf", document))
    result = subprocess.run([sys.executable, "-m", "game", "capture", str(folder / "s.toml"),
                             "--size", "16x9", "--out", str(tmp_path / "o")], cwd=ROOT,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "static[2].file" in lines[0], lines
    assert "m.bin: not a regular file" in lines[0], lines


def test_a_mesh_file_that_is_a_fifo_is_refused_not_opened(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    os.mkfifo(folder / "m.obj")
    expect_scene_error(capsys, folder, mesh_scene(folder, "m.obj"), None, "static[2].file",
                       "m.obj: not a regular file")


def chain_of_nodes(count: int) -> dict:
    document, _ = one_triangle()
    document["nodes"] = [{"mesh": 0, "children": [i + 1]} for i in range(count - 1)]
    document["nodes"].append({"mesh": 0})
    return document


def test_a_deep_chain_of_glb_nodes_is_refused_at_once(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    _, binary = one_triangle()
    start = time.perf_counter()
    expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", chain_of_nodes(5000), binary),
                       None, "static[2].file", "nodes nest deeper than",
                       str(gltf.MAX_NODE_DEPTH))
    assert time.perf_counter() - start < 10


def test_glb_node_count_and_node_cycles_are_one_line(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    count = gltf.MAX_NODES + 1
    document["nodes"] = [{} for _ in range(count)]
    expect_scene_error(capsys, folder, gltf_scene(folder, "many.glb", document, binary), None,
                       "static[2].file", f"{count:,} nodes", f"{gltf.MAX_NODES:,}")
    document["nodes"] = [{"mesh": 0, "children": [1]}, {"children": [0]}]
    expect_scene_error(capsys, folder, gltf_scene(folder, "loop.glb", document, binary), None,
                       "static[2].file", "node 0 has more than one parent")


def test_a_glb_within_the_node_limits_loads(tmp_path):
    from game.scene import load_scene

    folder = tmp_path / "scene"
    folder.mkdir()
    _, binary = one_triangle()
    text = gltf_scene(folder, "m.glb", chain_of_nodes(gltf.MAX_NODE_DEPTH), binary)
    (folder / "s.toml").write_text(text)
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == gltf.MAX_NODE_DEPTH


def test_a_gltf_instancing_bomb_is_refused_before_anything_is_allocated(capsys, tmp_path,
                                                                          monkeypatch):
    from game.scene.mesh_files import MAX_INSTANCED_TRIANGLES

    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    triangles = 30_000   # indices into the same three corners: 360 kB that draw 30,000 triangles
    indices = np.tile(np.array([0, 1, 2], np.uint32), triangles).tobytes()
    nodes = MAX_INSTANCED_TRIANGLES // triangles + 1
    document["accessors"][1]["count"] = 3 * triangles
    document["bufferViews"][1]["byteLength"] = len(indices)
    document["buffers"][0]["byteLength"] = 36 + len(indices)
    document["nodes"] = [{"mesh": 0, "translation": [i, 0, 0]} for i in range(nodes)]
    document["scenes"] = [{"nodes": list(range(nodes))}]
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got the file"))
    expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", document,
                                                  binary[:36] + indices),
                       None, "static[2].file", f"{nodes * triangles:,} triangles",
                       f"{MAX_INSTANCED_TRIANGLES:,}")


def data_uri_declaring_more() -> dict:
    import base64

    document, binary = one_triangle()
    uri = "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
    document["buffers"] = [{"uri": uri, "byteLength": 10**9}]
    document["bufferViews"][1]["byteLength"] = 1000   # inside what the buffer declares
    return document


def float_indices() -> dict:
    document, _ = one_triangle()
    document["accessors"][1]["componentType"] = 5126
    document["bufferViews"][1]["byteStride"] = 1
    return document


def scene_five() -> dict:
    document, _ = one_triangle()
    document.update(scene=5, scenes=[])
    return document


@pytest.mark.parametrize("make, fragment", [
    (data_uri_declaring_more, "buffer 0 declares 1,000,000,000 bytes; its data holds 48"),
    (float_indices, "byteStride 1"),
    (scene_five, "'scene' is 5, but the file has 0 scenes"),
])
def test_gltf_problems_are_named_in_the_projects_words(capsys, tmp_path, make, fragment):
    folder = tmp_path / "scene"
    folder.mkdir()
    _, binary = one_triangle()
    document = make()
    message = expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", document, binary),
                                 None, "static[2].file", "cannot read mesh m.glb", fragment)
    assert "Error" not in message and "index out of range" not in message


def test_float_indices_are_named(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    document["accessors"][1]["componentType"] = 5126
    expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", document, binary), None,
                       "static[2].file", "indices", "unsigned")


def test_a_gltf_buffer_in_a_parent_folder_inside_the_scene_folder_loads(capsys, tmp_path):
    from game.scene import load_scene

    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    (folder / "m.bin").write_bytes(binary)
    document["buffers"] = [{"uri": "../m.bin", "byteLength": len(binary)}]
    (folder / "s.toml").write_text(gltf_scene(folder, "sub/m.gltf", document))
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == 1
    (tmp_path / "x.bin").write_bytes(binary)
    document["buffers"] = [{"uri": "../../x.bin", "byteLength": len(binary)}]
    expect_scene_error(capsys, folder, gltf_scene(folder, "sub/m.gltf", document), None,
                       "static[2].file", "leaves the scene's folder")


@pytest.mark.parametrize("keyword", ["g", "o", "usemtl"])
def test_an_obj_with_more_groups_than_parts_is_refused_while_read(capsys, tmp_path,
                                                                    monkeypatch, keyword):
    from game.scene.parts import MAX_PARTS

    folder = tmp_path / "scene"
    folder.mkdir()
    count = MAX_PARTS + 1
    with open(folder / "m.obj", "w") as obj:
        obj.write("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
        obj.writelines(f"{keyword} part{i}\nf 1 2 3\n" for i in range(count))
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got the file"))
    expect_scene_error(capsys, folder, mesh_scene(folder, "m.obj"), None, "static[2].file",
                       f"more than {MAX_PARTS:,}")


def test_obj_groups_that_repeat_a_name_or_hold_no_faces_are_not_counted_twice(tmp_path):
    from game.scene import load_scene
    from game.scene.parts import MAX_PARTS

    folder = tmp_path / "scene"
    folder.mkdir()
    with open(folder / "m.obj", "w") as obj:
        obj.write("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
        obj.writelines(f"o empty{i}\ng same\nf 1 2 3\n" for i in range(3))
        obj.writelines("g same\r\nf 1 2 3\n" for _ in range(MAX_PARTS + 1))
    (folder / "s.toml").write_text(mesh_scene(folder, "m.obj"))
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == MAX_PARTS + 4


def test_hand_written_characters_past_the_limit_are_refused_at_once(capsys, tmp_path):
    from game.scene.loader import MAX_CHARACTERS

    walker = ('\n[[character]]\nshape = "capsule"\nradius = 0.3\nheight = 1.8\n'
              'path = [[-3.0, 0.9, -3.0], [3.0, 0.9, -3.0]]\n')
    start = time.perf_counter()
    expect_scene_error(capsys, tmp_path, TINY + walker * MAX_CHARACTERS, None,
                       f"character[{MAX_CHARACTERS}]", f"at most {MAX_CHARACTERS:,} characters")
    assert time.perf_counter() - start < 10


def test_glb_primitives_placed_past_the_limit_and_zero_accessors_in_all(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    primitive = document["meshes"][0]["primitives"][0]
    document["meshes"][0]["primitives"] = [primitive, primitive]
    nodes = gltf.MAX_NODES // 2 + 1
    document["nodes"] = [{"mesh": 0} for _ in range(nodes)]
    document["scenes"] = [{"nodes": list(range(nodes))}]
    expect_scene_error(capsys, folder, gltf_scene(folder, "prims.glb", document, binary), None,
                       "static[2].file", f"{2 * nodes:,} mesh primitives")
    document, binary = one_triangle()
    each = gltf.MAX_ZERO_ACCESSOR_BYTES // 12 * 2 // 3   # two thirds of the limit, twice
    document["accessors"] += [{"componentType": 5126, "count": each, "type": "VEC3"}] * 2
    expect_scene_error(capsys, folder, gltf_scene(folder, "zeros.glb", document, binary), None,
                       "static[2].file", "without data declare more than 64 MiB in all")
