"""``python -m game trace``, ``capture --method traced`` and ``capture --soft`` end to end."""

import json
import subprocess
import sys

import numpy as np
import pytest

from game.reference import hard as reference
from game.scene import load_scene
from tests.conftest import POINT, ROOT, TINY


def run(*args):
    return subprocess.run([sys.executable, "-m", "game", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_trace_writes_frames_dumps_and_stats(tmp_path):
    out = tmp_path / "out"
    result = run("trace", TINY, "--method", "voxel-cache", "--samples", "8", "--size", "64x36",
                 "--frames", "2", "--out", out, "--dump", "--stats", tmp_path / "s.json")
    assert result.returncode == 0, result.stderr
    for k in range(2):
        assert (out / f"frame_{k:04d}.png").is_file()
        assert (out / f"frame_{k:04d}.glb").is_file()
        d = np.load(out / f"frame_{k:04d}.npz")
        soft = d["soft"]
        assert soft.shape == (36, 64) and soft.dtype == np.float32
        geometry = np.isfinite(d["position"]).all(axis=-1)
        assert np.array_equal(np.isfinite(soft), geometry)
        assert ((soft[geometry] >= 0) & (soft[geometry] <= 1)).all()
    stats = json.loads((tmp_path / "s.json").read_text())
    assert stats["clock"] in ("cpu-finish", "gpu-query") and stats["renderer"]
    assert stats["method"] == "voxel-cache" and stats["samples"] == 8
    for f in stats["frames"]:
        for key in ("build", "trace", "total", "ray_triangle_tests", "triangle_triangle_tests",
                    "voxels_visited", "candidates", "overflows", "maps_rendered",
                    "triangles_to_maps"):
            assert key in f, key
        assert f["ms"]["total"] >= f["ms"]["trace"] > 0
    # The statics' grid is built once: only the first frame pays for it.
    assert stats["frames"][0]["build_static"] > 0 and stats["frames"][1]["build_static"] == 0


@pytest.mark.parametrize("args, fragment, status", [
    (["--samples", "0"], "--samples", 2),
    (["--method", "magic"], "--method", 2),
    (["--vc-slots", "3"], "--vc-slots", 2),
    (["--cells-per-triangle", "-1"], "--cells-per-triangle", 2),
])
def test_trace_bad_arguments_are_one_line(args, fragment, status, tmp_path):
    result = run("trace", TINY, "--out", tmp_path / "o", *args)
    assert result.returncode == status
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in result.stderr


def test_trace_without_a_linear_light_is_one_line(tmp_path):
    scene = tmp_path / "nolight.toml"
    text = TINY.read_text()
    start = text.index("[linear_light]")
    end = text.index("[[floor]]")
    scene.write_text(text[:start] + text[end:])
    for args in (["trace", scene], ["capture", scene, "--soft"]):
        result = run(*args, "--out", tmp_path / "o", "--size", "32x18")
        assert result.returncode == 1
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and "linear_light" in lines[0]


def test_capture_traced_matches_embree_hard_shadows(tmp_path):
    out = tmp_path / "out"
    result = run("capture", POINT, "--method", "traced", "--size", "160x90", "--out", out,
                 "--dump")
    assert result.returncode == 0, result.stderr
    frame = reference.load_frame(out / "frame_0000.npz")
    mesh = reference.load_geometry(out / "frame_0000.glb")
    scene_light = load_scene(POINT).light
    exact = reference.hard_visibility(mesh, frame["position"], frame["normal"], scene_light)
    err = reference.shadow_error(frame["lit"], exact, frame["position"], frame["normal"],
                                 scene_light)
    assert err["shadowed"] > 200
    assert err["misclassified"] <= 0.002 * err["considered"]


def test_capture_soft_changes_the_image_and_dumps_soft(tmp_path):
    hard, soft = tmp_path / "hard", tmp_path / "soft"
    assert run("capture", TINY, "--size", "64x36", "--out", hard, "--dump").returncode == 0
    result = run("capture", TINY, "--size", "64x36", "--out", soft, "--dump", "--soft",
                 "--stats", tmp_path / "s.json")
    assert result.returncode == 0, result.stderr
    a = np.load(hard / "frame_0000.npz")
    b = np.load(soft / "frame_0000.npz")
    assert "soft" in b.files and "soft" not in a.files
    assert (hard / "frame_0000.png").read_bytes() != (soft / "frame_0000.png").read_bytes()
    stats = json.loads((tmp_path / "s.json").read_text())
    ms = stats["frames"][0]["ms"]
    assert ms["total"] >= ms["soft_trace"] > 0


def test_sweep_writes_csv_json_and_chart(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "game.bench.soft_sweep", str(TINY), "--size", "48x27", "--samples",
         "1,4", "--methods", "grid,voxel-cache", "--out", str(tmp_path), "--name", "s"],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    stats = json.loads((tmp_path / "s.json").read_text())
    rows = stats["rows"]
    assert [(r["method"], r["samples"]) for r in rows] == [
        ("analytic", 0), ("grid", 1), ("voxel-cache", 1), ("grid", 4), ("voxel-cache", 4)]
    for r in rows[1:]:
        assert r["embree_ms"] > 0 and r["trace_ms"] > 0 and r["truncated"] == 0
    assert rows[3]["rmse_analytic"] < rows[1]["rmse_analytic"]
    assert (tmp_path / "s.csv").read_text().startswith("method,samples,")
    for chart in ("s.png", "s_counters.png"):
        assert (tmp_path / chart).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sweep_refuses_bad_values_in_one_line():
    for args, code in ((["--size", "abc"], 2), (["--samples", "0,4"], 2),
                       (["--methods", "grid,nope"], 2), (["missing.toml"], 1)):
        result = subprocess.run([sys.executable, "-m", "game.bench.soft_sweep", *args], cwd=ROOT,
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == code, (args, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
