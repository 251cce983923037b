"""``python -m game trace``, ``capture --method traced`` and ``capture --soft`` end to end."""

import json

import numpy as np
import pytest

from game.reference import hard as reference
from game.scene import load_scene
from tests.cli.cli_helpers import in_process
from tests.helpers import POINT, ROOT, TINY


def test_trace_writes_frames_dumps_and_stats(capsys, tmp_path):
    game = in_process(capsys)
    out = tmp_path / "out"
    result = game("trace", TINY, "--method", "voxel-cache", "--samples", "8", "--size", "64x36",
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
                    "triangles_to_maps", "rounds", "step_budget", "dispatches"):
            assert key in f, key
        assert f["ms"]["total"] >= f["ms"]["trace"] > 0
        assert f["truncated_points"] == 0 and f["rounds"] >= 1
        # Memory traffic per shaded point, by what is read, and its total.
        parts = [f[k] for k in ("bytes_triangles", "bytes_cells", "bytes_candidates")]
        assert min(parts) > 0 and f["bytes_total"] == pytest.approx(sum(parts), abs=1e-3)
    assert stats["grid"]["structure"] == stats["settings"]["structure"]
    # The statics' grid is built once: only the first frame pays for it.
    assert stats["frames"][0]["build_static"] > 0 and stats["frames"][1]["build_static"] == 0


REAL_LEVEL = ROOT / "assets" / "real" / "monastery.toml"


@pytest.mark.skipif(not REAL_LEVEL.exists(), reason="the real level is fetched by "
                    "assets/fetch_real.py")
def test_trace_of_the_real_level_cuts_no_point_short(ctx):
    # Before its work was split, analytic ran out of llvmpipe's loop budget on most points of
    # this level (125,000 triangles, a light triangle spanning the whole compound). Both
    # methods in one renderer, which makes the G-buffer and the statics' grid once (the command
    # line's trace is tested above, on the tiny scene).
    from game.render.renderer import Renderer, View
    from game.soft.tracer import TraceSettings

    scene = load_scene(REAL_LEVEL)
    size = (48, 27)
    renderer = Renderer(ctx, scene, size, gbuffer=True)
    try:
        view = View.from_camera(scene.camera, size)
        for method in ("analytic", "voxel-cache"):
            result = renderer.render(0.0, view, soft=TraceSettings(method=method, samples=8)).soft
            assert int(result.covered.sum()) > 500, method
            assert result.truncated == 0 and result.rounds >= 1, method
    finally:
        renderer.release()


@pytest.mark.parametrize("args, fragment, status", [
    (["--samples", "0"], "--samples", 2),
    (["--method", "magic"], "--method", 2),
    (["--vc-slots", "3"], "--vc-slots", 2),
    (["--cells-per-triangle", "-1"], "--cells-per-triangle", 2),
])
def test_trace_bad_arguments_are_one_line(capsys, args, fragment, status, tmp_path):
    game = in_process(capsys)
    result = game("trace", TINY, "--out", tmp_path / "o", *args)
    assert result.returncode == status
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in result.stderr


def test_trace_without_a_linear_light_is_one_line(capsys, tmp_path):
    game = in_process(capsys)
    scene = tmp_path / "nolight.toml"
    text = TINY.read_text()
    start = text.index("[linear_light]")
    end = text.index("[[floor]]")
    scene.write_text(text[:start] + text[end:])
    for args in (["trace", scene], ["capture", scene, "--soft"]):
        result = game(*args, "--out", tmp_path / "o", "--size", "32x18")
        assert result.returncode == 1
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and "linear_light" in lines[0]


def test_capture_traced_matches_embree_hard_shadows(capsys, tmp_path):
    game = in_process(capsys)
    out = tmp_path / "out"
    result = game("capture", POINT, "--method", "traced", "--size", "160x90", "--out", out,
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


def test_capture_soft_changes_the_image_and_dumps_soft(capsys, tmp_path):
    game = in_process(capsys)
    hard, soft = tmp_path / "hard", tmp_path / "soft"
    assert game("capture", TINY, "--size", "64x36", "--out", hard, "--dump").returncode == 0
    result = game("capture", TINY, "--size", "64x36", "--out", soft, "--dump", "--soft",
                 "--stats", tmp_path / "s.json")
    assert result.returncode == 0, result.stderr
    a = np.load(hard / "frame_0000.npz")
    b = np.load(soft / "frame_0000.npz")
    assert "soft" in b.files and "soft" not in a.files
    assert (hard / "frame_0000.png").read_bytes() != (soft / "frame_0000.png").read_bytes()
    stats = json.loads((tmp_path / "s.json").read_text())
    ms = stats["frames"][0]["ms"]
    assert ms["total"] >= ms["soft_trace"] > 0


def test_sweep_writes_csv_json_and_chart(capsys, tmp_path):
    from game.bench import soft_sweep

    assert soft_sweep.main([str(TINY), "--size", "48x27", "--samples", "1,4", "--methods",
                            "grid,voxel-cache", "--out", str(tmp_path), "--name", "s"]) == 0, \
        capsys.readouterr().err
    stats = json.loads((tmp_path / "s.json").read_text())
    rows = stats["rows"]
    assert [(r["method"], r["samples"]) for r in rows] == [
        ("analytic", 0), ("grid", 1), ("voxel-cache", 1), ("grid", 4), ("voxel-cache", 4)]
    for r in rows[1:]:
        assert r["embree_ms"] > 0 and r["trace_ms"] > 0 and r["truncated"] == 0
    assert rows[3]["rmse_analytic"] < rows[1]["rmse_analytic"]
    assert (tmp_path / "s.csv").read_text().startswith("scene,structure,method,samples,")
    for chart in ("s.png", "s_counters.png"):
        assert (tmp_path / chart).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sweep_of_several_scenes_and_structures_sets_rays_per_second_beside_embree(capsys,
                                                                                  tmp_path):
    from game.bench import soft_sweep
    from tests.helpers import COURTYARD

    assert soft_sweep.main(["--scenes", f"{TINY},{COURTYARD}", "--structures",
                            "uniform,two-level", "--size", "40x24", "--samples", "2",
                            "--methods", "grid,voxel-cache", "--repeats", "1", "--out",
                            str(tmp_path), "--name", "s"]) == 0, capsys.readouterr().err
    rows = json.loads((tmp_path / "s.json").read_text())["rows"]
    assert {(r["scene"], r["structure"]) for r in rows} == {
        (scene, structure) for scene in ("tiny", "courtyard")
        for structure in ("uniform", "two-level")}
    for r in rows:
        assert r["truncated"] == 0
        if r["method"] != "analytic":
            assert r["rays"] > 0 and r["rays_per_s"] > 0 and r["embree_rays_per_s"] > 0
            assert r["bytes_total"] > 0
    # Same rays, so the same visibility error whatever the structure.
    for scene in ("tiny", "courtyard"):
        errors = {r["rmse_embree"] for r in rows if r["scene"] == scene
                  and r["method"] == "voxel-cache"}
        assert len(errors) == 1
    for chart in ("s_tiny.png", "s_courtyard_counters.png", "s_rays.png"):
        assert (tmp_path / chart).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, code", [(["--size", "abc"], 2), (["--samples", "0,4"], 2),
                                         (["--methods", "grid,nope"], 2),
                                         (["--structures", "octree"], 2),
                                         (["missing.toml"], 1)])
def test_sweep_refuses_bad_values_in_one_line(capsys, args, code):
    from game.bench import soft_sweep

    assert soft_sweep.main(args) == code, args
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
