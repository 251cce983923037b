"""Every class of bad input through the command line: exit non-zero, one line, no traceback.

tests/scene/test_loader.py checks the loader's messages case by case; this file runs each class of
bad input end to end through ``game.cli.main`` (in process, so it is quick) and checks what a user
sees: the exit status and one stderr line naming the file, the line, the key and the problem. The
table in docs/reliability.md lists the same cases with their messages.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
import trimesh

from tests.cli.cli_helpers import MESH, expect_scene_error, run_main
from tests.helpers import TINY as TINY_PATH

TINY = TINY_PATH.read_text()


def line_of(text: str, needle: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if needle in ln)


# (case, old text in tiny.toml, new text, key in the message, fragments)
REPLACEMENTS = [
    ("toml syntax", 'shape    = "box"', "shape    = box", "TOML syntax error", ["line"]),
    ("unknown key", "fov      = 60.0", "fvo      = 60.0", "camera.fvo",
     ["unknown key", "did you mean 'fov'"]),
    ("unknown shape", 'shape    = "sphere"', 'shape    = "sphear"', "static[1].shape",
     ["did you mean 'sphere'"]),
    ("missing key", "radius   = 0.7\n", "\n", "static[1].radius", ["missing required key"]),
    ("wrong type", "radius   = 0.7", 'radius   = "0.7"', "static[1].radius",
     ["must be a number"]),
    ("wrong type vector", "size     = [1.5, 2.0, 1.0]", "size     = [1.5, 2.0]",
     "static[0].size", ["3 numbers"]),
    ("nan", "radius   = 0.7", "radius   = nan", "static[1].radius", ["finite"]),
    ("infinity", "position = [1.5, 0.7, 0.8]", "position = [1.5, inf, 0.8]",
     "static[1].position", ["finite"]),
    ("zero size", "size     = [1.5, 2.0, 1.0]", "size     = [1.5, 0.0, 1.0]",
     "static[0].size", ["positive"]),
    ("negative size", "radius   = 0.7", "radius   = -0.7", "static[1].radius", ["positive"]),
    ("zero light direction", "direction = [-0.4, -1.0, -0.3]", "direction = [0.0, 0.0, 0.0]",
     "light.direction", ["must not be zero"]),
    ("range on a directional light", "direction = [-0.4, -1.0, -0.3]",
     "direction = [-0.4, -1.0, -0.3]\nrange = 10.0", "light.range",
     ["not used by a 'directional' light"]),
    ("negative light intensity", "direction = [-0.4, -1.0, -0.3]",
     "direction = [-0.4, -1.0, -0.3]\nintensity = -1.0", "light.intensity",
     ["must not be negative"]),
    ("empty path", "path   = [[-3.0", "path   = []\n#", "character[0].path",
     ["non-empty list"]),
    ("zero-length path", "path   = [[-3.0, 0.9, -3.0], [3.0, 0.9, -3.0]",
     "path   = [[1.0, 0.9, 1.0], [1.0, 0.9, 1.0]]\n#", "character[0].path", ["zero length"]),
    ("zero scale", "radius   = 0.7", "radius   = 0.7\nscale = 0", "static[1].scale",
     ["positive"]),
    ("zero fov", "fov      = 60.0", "fov      = 0.0", "camera.fov", ["positive"]),
]


@pytest.mark.parametrize(("case", "old", "new", "key", "fragments"), REPLACEMENTS,
                         ids=[r[0] for r in REPLACEMENTS])
def test_bad_scene_values(capsys, tmp_path, case, old, new, key, fragments):
    assert old in TINY
    text = TINY.replace(old, new, 1)
    # The line of the changed key (the TOML parser names its own line for syntax errors).
    first_new = new.splitlines()[-1] if new.strip().startswith("scale") else new.splitlines()[0]
    if case == "missing key":
        line = line_of(text, 'shape    = "sphere"') - 1  # the [[static]] header
    elif case == "zero scale":
        line = line_of(text, "scale = 0")
    elif new.startswith(old + "\n"):  # a key added after the old one: the message names it
        line = line_of(text, new.splitlines()[-1])
    else:
        line = line_of(text, first_new.strip() or new)
    expect_scene_error(capsys, tmp_path, text, line, key, *fragments)


def write_mesh_scene(tmp_path: Path, file: str) -> str:
    return TINY + MESH.format(file=file)


MESH_LINE = line_of(TINY + MESH.format(file="x"), 'file = "x"')

MESH_FILES = {
    "missing": (None, "file not found"),
    "empty obj": ("empty.obj", "empty file"),
    "empty glb": ("empty.glb", "empty file"),
    "not a mesh": ("text.obj", "no triangles"),
    "garbage ply": ("junk.ply", "cannot read mesh"),
    "wrong suffix": ("notes.txt", "unsupported mesh format"),
    "degenerate": ("flat.obj", "zero area"),
    "non-finite": ("nan.obj", "non-finite"),
    "index out of range": ("oob.obj", "cannot read mesh"),
    "leaves folder": ("../outside.obj", "leaves the scene's folder"),
    "absolute": ("ABSOLUTE", "absolute paths are not allowed"),
    "symlink out": ("link.obj", "outside the scene's folder"),
}


@pytest.fixture
def mesh_folder(tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    for name in ("empty.obj", "empty.glb"):
        (folder / name).write_bytes(b"")
    (folder / "text.obj").write_text("this is not a mesh\n")
    (folder / "junk.ply").write_bytes(b"garbage!")
    (folder / "notes.txt").write_text("hello")
    (folder / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    (folder / "nan.obj").write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    (folder / "oob.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n")
    trimesh.creation.box().export(tmp_path / "outside.obj")
    (folder / "link.obj").symlink_to(tmp_path / "outside.obj")
    return folder


@pytest.mark.parametrize("case", list(MESH_FILES))
def test_bad_mesh_files(capsys, mesh_folder, case):
    file, fragment = MESH_FILES[case]
    if file is None:
        file = "models/nothere.obj"
    if file == "ABSOLUTE":
        file = (mesh_folder.parent / "outside.obj").as_posix()
    expect_scene_error(capsys, mesh_folder, write_mesh_scene(mesh_folder, file), MESH_LINE,
                       "static[2].file", fragment)


def test_unreadable_mesh_file(capsys, mesh_folder, monkeypatch):
    # chmod 000 does not stop root (CI containers), so make the open itself fail.
    target = mesh_folder / "locked.obj"
    trimesh.creation.box().export(target)
    real_open = os.open

    def refuse(path, *args, **kwargs):
        if Path(path).name == "locked.obj":
            raise PermissionError(13, "Permission denied")
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    expect_scene_error(capsys, mesh_folder, write_mesh_scene(mesh_folder, "locked.obj"),
                       MESH_LINE, "static[2].file", "cannot open", "Permission denied")


def test_path_leaving_the_folder_is_refused_before_opening(capsys, mesh_folder, monkeypatch):
    opened = []
    real_open = Path.open

    def spy(self, *args, **kwargs):
        opened.append(self.name)
        return real_open(self, *args, **kwargs)

    monkeypatch.setattr(Path, "open", spy)
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: opened.append("trimesh") or 1 / 0)
    expect_scene_error(capsys, mesh_folder, write_mesh_scene(mesh_folder, "../outside.obj"),
                       MESH_LINE, "static[2].file", "leaves")
    assert "outside.obj" not in opened and "trimesh" not in opened


@pytest.mark.parametrize(("args", "flag"), [
    (["--size", "0x10"], "--size"),
    (["--size", "-5x10"], "--option=VALUE"),
    (["--size=-5x10"], "--size"),
    (["--size", "20000x10"], "--size"),
    (["--size", "10"], "--size"),
    (["--frames", "0"], "--frames"),
    (["--frames", "-3"], "--frames"),
    (["--frames", "1.5"], "--frames"),
    (["--fps", "0"], "--fps"),
    (["--fps", "-30"], "--fps"),
    (["--fps", "inf"], "--fps"),
    (["--fps", "nan"], "--fps"),
    (["--time", "nan"], "--time"),
    (["--method", "magic"], "--method"),
    (["--method", ""], "--method"),
    (["--clumps", "0"], "--clumps"),
    (["--texels-per-metre", "-1"], "--texels-per-metre"),
    (["--normal-bias", "-1"], "--normal-bias"),
])
def test_bad_command_line_values(capsys, tmp_path, args, flag):
    scene = tmp_path / "tiny.toml"
    scene.write_text(TINY)
    code, lines = run_main(capsys, "capture", scene, *args, "--out", tmp_path / "out")
    assert code == 2
    assert len(lines) == 1 and flag in lines[0], lines
    assert re.match(r"^error: ", lines[0])


@pytest.mark.parametrize("args", [
    ["capture", "--size", "16x9", "--out", ""],
    ["trace", "--size", "16x9", "--out", " "],
    ["capture", "--size", "16x9", "--stats", ""],
    ["scenes", "random", "--seed", "1", "--out", ""],
    ["verify", ""],
])
def test_an_empty_path_is_refused_not_taken_for_the_current_folder(capsys, tmp_path,
                                                                    monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    code, lines = run_main(capsys, *args)
    assert code == 2 and len(lines) == 1 and "an empty path" in lines[0], lines
    assert not any(tmp_path.iterdir())


def test_a_run_that_fails_before_its_first_frame_leaves_no_folder(capsys, tmp_path):
    out = tmp_path / "made" / "here"
    code, lines = run_main(capsys, "trace", "--size", "16384x16384", "--out", out)
    assert code == 1 and len(lines) == 1 and "GPU memory" in lines[0], lines
    assert not (tmp_path / "made").exists()


@pytest.mark.parametrize("address", ["notanaddress", "tcp://127.0.0.1:99999", ""])
def test_a_cluster_address_dask_cannot_read_is_one_line_at_once(capsys, tmp_path, address):
    pytest.importorskip("distributed")
    code, lines = run_main(capsys, "bench", "--suite", "accuracy", "--seeds", "1",
                           "--cluster", address, "--out", tmp_path / "out")
    assert code == 2 and len(lines) == 1 and "--cluster" in lines[0], lines
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("param", "fragment"), [
    ("clump_resolution=1", "16..1000000"),
    ("clump_resolution=512,999999999999", "16..1000000"),
    ("single_resolution=3", "single_resolution"),
])
def test_bench_param_values_meet_the_bounds_of_captures_flags(capsys, tmp_path, param,
                                                              fragment):
    code, lines = run_main(capsys, "bench", "--scenes", "default", "--param", param, "--list",
                           "--out", tmp_path / "out")
    assert code == 2 and len(lines) == 1 and fragment in lines[0], lines
    assert lines[0].startswith("error: --param ")


@pytest.mark.parametrize("flag", ["--scenes", "--methods"])
@pytest.mark.parametrize("value", ["", " "])
def test_an_empty_bench_selection_is_refused_not_read_as_the_whole_sweep(capsys, tmp_path, flag,
                                                                         value):
    code, lines = run_main(capsys, "bench", flag, value, "--out", tmp_path / "out")
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"error: {flag}: empty"), lines
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not Path("/proc/version").is_file(), reason="a Linux /proc")
@pytest.mark.parametrize("flags", [["--stats", "/proc/version"], ["--out", "/proc/new_folder"]])
def test_an_output_where_no_file_can_be_made_is_refused_before_any_work(capsys, tmp_path, flags):
    """The kernel's folders take no file whatever their permission bits say (and root passes
    every permission check): the check makes a file there, as the run would."""
    args = ["--out", tmp_path / "out", *flags] if flags[0] == "--stats" else flags
    code, lines = run_main(capsys, "capture", "--size", "16x9", *args)
    assert code == 2 and len(lines) == 1 and "/proc" in lines[0], lines
    assert not (tmp_path / "out").exists()


def test_a_value_thousands_of_characters_long_stays_a_short_line(capsys):
    digits = "9" * 5001
    code, lines = run_main(capsys, "capture", "--size", f"{digits}x9")
    assert code == 2 and len(lines) == 1 and len(lines[0]) < 200, lines
    assert re.search(r"\.\.\.9+x9. \(\d{4} characters\)", lines[0]), lines
    code, lines = run_main(capsys, "scenes", "random", "--seed", digits)
    assert code == 2 and len(lines) == 1 and "5001 digits is too long to read" in lines[0], lines
