"""The command line: every bad input is one line on stderr and a non-zero exit, no traceback."""

import json
import os

import numpy as np
import pytest

from tests.cli.cli_helpers import assert_one_line_error, in_process, run
from tests.helpers import TINY


@pytest.mark.parametrize("args, fragment", [
    (["capture", TINY, "--size", "0x10"], "--size"),
    (["capture", TINY, "--size", "wide"], "--size"),
    (["capture", TINY, "--frames", "0"], "--frames"),
    (["capture", TINY, "--frames", "two"], "--frames"),
    (["capture", TINY, "--fps", "0"], "--fps"),
    (["capture", TINY, "--fps", "nan"], "--fps"),
    (["capture", TINY, "--time", "inf"], "--time"),
    (["capture", TINY, "--method", "magic"], "--method"),
    (["capture", TINY, "--clumping", "diagonal"], "--clumping"),
    (["capture", TINY, "--no-such-flag"], "--no-such-flag"),
    (["capture", "missing.toml"], "missing.toml"),
    (["frobnicate"], "frobnicate"),
])
def test_bad_arguments(capsys, args, fragment, tmp_path):
    game = in_process(capsys)
    assert_one_line_error(game(*args, "--out", tmp_path / "out") if args[0] == "capture"
                          else game(*args), fragment)


def test_bad_scene_is_one_line_naming_file_line_and_key(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text(TINY.read_text().replace("radius   = 0.7", "radius   = -0.7"))
    result = run("capture", scene, "--out", tmp_path / "out")
    assert result.returncode == 1
    assert_one_line_error(result, "bad.toml:", "radius")


def test_out_that_is_a_file(capsys, tmp_path):
    game = in_process(capsys)
    target = tmp_path / "file"
    target.write_text("keep me")
    assert_one_line_error(game("capture", TINY, "--out", target), "--out")
    assert target.read_text() == "keep me"


def test_capture_writes_frames_dumps_and_stats(capsys, tmp_path):
    game = in_process(capsys)
    out = tmp_path / "out"
    result = game("capture", TINY, "--frames", "2", "--size", "64x36", "--out", out, "--dump",
                 "--stats", tmp_path / "stats.json", "--time", "1.5", "--fps", "10")
    assert result.returncode == 0, result.stderr
    for k in range(2):
        assert (out / f"frame_{k:04d}.png").read_bytes()[:4] == b"\x89PNG"
        assert (out / f"frame_{k:04d}.glb").read_bytes()[:4] == b"glTF"
        with np.load(out / f"frame_{k:04d}.npz") as dump:
            assert dump["position"].shape == (36, 64, 3) and dump["position"].dtype == np.float32
            assert dump["normal"].shape == (36, 64, 3)
            assert dump["object"].dtype == np.int32
            assert dump["lit"].dtype == np.float32
            assert list(dump["names"]) == ["floor_0", "static_0", "static_1", "character_0"]
            assert dump["view"].dtype == np.float64 and dump["proj"].shape == (4, 4)
            assert list(dump["size"]) == [64, 36]
            assert float(dump["time"]) == pytest.approx(1.5 + k / 10)
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["clock"] == "cpu-finish" and "llvmpipe" in stats["renderer"]
    assert stats["version"]
    assert len(stats["frames"]) == 2
    for frame in stats["frames"]:
        for key in ("shadow_static", "shadow_dynamic", "shade", "total"):
            assert frame["ms"][key] >= 0 and frame[key] == frame["ms"][key]
        assert frame["maps_rendered"] >= 1
        assert frame["triangles_to_maps"] > 0
        assert 0 < frame["maps_per_fragment"] < 3
    first, second = stats["frames"]
    assert first["maps_rendered"] == first["maps_total"] > 1  # clumps and the character
    assert second["maps_rendered"] == 1 and second["maps_cached"] == first["maps_total"] - 1
    assert not list(out.glob("*.tmp")) and not list(out.glob(".*"))


def test_default_command_renders_headless_and_says_where(tmp_path):
    # With a display, python -m game would open the walkaround: take the display away.
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = run(cwd=tmp_path, env=env)
    assert result.returncode == 0, result.stderr
    assert len(result.stdout.strip().splitlines()) == 1
    assert "headless" in result.stdout
    assert (tmp_path / "captures" / "square" / "frame_0000.png").exists()


def test_verify_reports_the_error_of_each_dumped_frame(capsys, tmp_path):
    game = in_process(capsys)
    pytest.importorskip("embreex")
    out = tmp_path / "dumps"
    assert game("capture", TINY, "--frames", "2", "--size", "96x54", "--out", out,
               "--dump").returncode == 0
    result = game("verify", out, TINY, "--out", tmp_path / "verify.json")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.strip().splitlines()
    assert [line.split(":")[0] for line in lines] == ["frame_0000", "frame_0001"]
    report = json.loads((tmp_path / "verify.json").read_text())
    assert [f["frame"] for f in report["frames"]] == ["frame_0000", "frame_0001"]
    assert all(0 <= f["error"] <= 0.2 and f["shadowed"] > 0 for f in report["frames"])


def test_verify_without_dumps_is_one_line(capsys, tmp_path):
    game = in_process(capsys)
    assert_one_line_error(game("verify", tmp_path), "no frame_*.npz")


def test_a_warning_is_one_line(tmp_path):
    (tmp_path / "deg.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n")  # the first is degenerate
    scene = tmp_path / "scene.toml"
    scene.write_text(TINY.read_text() + '\n[[static]]\nshape = "mesh"\nfile = "deg.obj"\n')
    result = run("capture", scene, "--size", "32x18", "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: ") and "zero-area" in lines[0]


@pytest.mark.parametrize("args", [
    ["bench", "--scenes", "nope"],
    ["capture", "--method", "traced", "--debug-view", "map"],
    ["capture", "--soft", "--debug-view", "cache"],
])
def test_refused_combinations_get_one_line(capsys, args, tmp_path):
    game = in_process(capsys)
    result = game(*args, cwd=tmp_path)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr


def test_a_depth_array_past_every_budget_is_never_asked_of_the_driver(capsys, tmp_path):
    game = in_process(capsys)
    # 1,000 cascades: past the bound of the flag, one line before anything is made.
    result = game("capture", str(TINY), "--method", "csm", "--cascades", "1000",
                 "--cascade-resolution", "16384", "--size", "32x18", "--out", str(tmp_path),
                 cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "error: python -m game capture: argument --cascades: must be 1..64, got '1000'"]
    # 64 cascades of 16384² (64 GiB): the baselines' budget halves the maps, and says so.
    result = game("capture", str(TINY), "--method", "csm", "--cascades", "64",
                 "--cascade-resolution", "16384", "--size", "32x18", "--out", str(tmp_path),
                 cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert any(line.startswith("note: csm:") and "halved" in line
               for line in result.stderr.splitlines()), result.stderr
