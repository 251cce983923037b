"""``verify --images``, ``verify`` of soft dumps, and its figures in percent: pictures of where a
method and Embree disagree, written beside each frame, on dumps built by hand
(tests/reference/hand_made_dumps.py) and on a real trace of the tiny scene."""

from __future__ import annotations

import json

import numpy as np
import pytest

from game import cli
from game.reference.error_picture import KINDS
from tests.helpers import TINY, decode_png
from tests.reference.hand_made_dumps import floor_frame, scene_text, true_lit, write_dump

pytest.importorskip("embreex", reason="verify needs embreex (pip install embreex)")

COLOURS = {name: colour for name, colour, _ in KINDS}


def verify(capsys, *args) -> tuple[int, list[str], list[str]]:
    code = cli.main(["verify", *(str(a) for a in args)])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out.strip().splitlines(), captured.err.strip().splitlines()


def shadow_missed() -> tuple[np.ndarray, np.ndarray]:
    """Light 0's true visibility, and a method that lights its whole shadow (16 pixels)."""
    position, _ = floor_frame()
    right = true_lit(position, 0)
    return right, np.where(np.isfinite(right), 1.0, np.nan).astype(np.float32)


def test_images_paint_the_missed_shadow_orange_and_count_it(capsys, tmp_path):
    right, all_lit = shadow_missed()
    write_dump(tmp_path, scene_text(point_light=False), [all_lit])
    code, out, err = verify(capsys, tmp_path, "--images")
    assert code == 0, err
    assert out[0].startswith("frame_0000: error 100.00% (16 misclassified of 16 ")
    assert out[1] == ("  wrote frame_0000_errors.png: orange: lit where the reference shadows "
                      "16; blue: shadowed where the reference lights 0; purple: left out, the "
                      "reference changes with the ray offset 0; grey stripes: left out, N.L too "
                      "low or out of the light's reach 0")
    image = decode_png((tmp_path / "frame_0000_errors.png").read_bytes())
    assert image.shape == (20, 20, 3)
    orange = (image == COLOURS["too_lit"]).all(axis=-1)
    np.testing.assert_array_equal(orange, right == 0.0)
    # Nothing else is left in the folder: no temp file, no picture of another name.
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "frame_0000.glb", "frame_0000.npz", "frame_0000_errors.png", "scene.toml"]


def test_a_scene_of_several_lights_gets_a_picture_per_light(capsys, tmp_path):
    right, all_lit = shadow_missed()
    position, _ = floor_frame()
    write_dump(tmp_path, scene_text(), [right, true_lit(position, 1)])
    code, out, err = verify(capsys, tmp_path, "--images")
    assert code == 0, err
    assert [line.split(":")[0] for line in out] == [
        "frame_0000 light 0 (directional)", "  wrote frame_0000_light0_errors.png",
        "frame_0000 light 1 (point)", "  wrote frame_0000_light1_errors.png"]
    for k in (0, 1):
        image = decode_png((tmp_path / f"frame_0000_light{k}_errors.png").read_bytes())
        assert not np.isin(image.reshape(-1, 3), [COLOURS["too_lit"], COLOURS["too_dark"]]
                           ).all(axis=-1).any()


def test_without_images_no_picture_is_written(capsys, tmp_path):
    _, all_lit = shadow_missed()
    write_dump(tmp_path, scene_text(point_light=False), [all_lit])
    code, out, _ = verify(capsys, tmp_path)
    assert code == 0 and len(out) == 1
    assert not list(tmp_path.glob("*_errors.png"))


def test_a_picture_path_in_the_way_is_refused_before_any_work(capsys, tmp_path):
    _, all_lit = shadow_missed()
    write_dump(tmp_path, scene_text(point_light=False), [all_lit])
    (tmp_path / "frame_0000_errors.png").mkdir()
    code, out, err = verify(capsys, tmp_path, "--images", "--out", tmp_path / "v.json")
    assert code == 2 and out == [] and len(err) == 1, (out, err)
    assert "--images" in err[0] and "frame_0000_errors.png" in err[0]
    assert not (tmp_path / "v.json").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_a_soft_dump_is_scored_on_soft_and_says_so(capsys, tmp_path):
    position, _ = floor_frame()
    sky = ~np.isfinite(position[..., 0])
    all_lit = np.where(sky, np.nan, 1.0)
    write_dump(tmp_path, scene_text(point_light=False, linear_light=True),
               [true_lit(position, 0)], soft=all_lit)
    code, out, err = verify(capsys, tmp_path, "--images", "--out", tmp_path / "v.json")
    assert code == 0, err
    assert out[0].startswith("frame_0000 soft: rmse 0.")
    assert "% of points off by more than 0.1 (" in out[0]
    assert "stratified Embree samples of the linear light" in out[0]
    frame = json.loads((tmp_path / "v.json").read_text())["frames"][0]
    assert frame["kind"] == "soft" and frame["points"] == 399
    assert frame["off"] > 0 and frame["off_share"] == frame["off"] / 399
    assert f"orange: sees more of the light than the reference, by over 0.1 {frame['off']};" \
        in out[1]
    image = decode_png((tmp_path / "frame_0000_errors.png").read_bytes())
    assert (image == COLOURS["too_lit"]).all(axis=-1).sum() == frame["off"]


def test_a_soft_dump_of_a_scene_without_a_linear_light_is_one_line(capsys, tmp_path):
    position, _ = floor_frame()
    write_dump(tmp_path, scene_text(point_light=False), [true_lit(position, 0)],
               soft=np.zeros(position.shape[:2]))
    code, out, err = verify(capsys, tmp_path)
    assert code == 1 and len(err) == 1 and "no [linear_light]" in err[0], err


def test_a_trace_of_the_tiny_scene_scores_its_soft_visibility(capsys, tmp_path):
    """End to end: the tracer's own ``soft`` is close to the Embree reference."""
    out_dir = tmp_path / "trace"
    assert cli.main(["trace", str(TINY), "--dump", "--size", "48x27", "--samples", "16",
                     "--out", str(out_dir)]) == 0
    capsys.readouterr()
    code, out, err = verify(capsys, out_dir, "--out", tmp_path / "v.json")
    assert code == 0, err
    assert out[0].startswith("frame_0000 soft: rmse ")
    frame = json.loads((tmp_path / "v.json").read_text())["frames"][0]
    assert frame["points"] > 500 and frame["rmse"] < 0.05 and frame["off_share"] < 0.02, frame
