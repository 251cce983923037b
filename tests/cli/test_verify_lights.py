"""``verify`` on scenes of several lights: one line per frame per light, and each light's error in
``--out``, on dumps built by hand (tests/reference/hand_made_dumps.py); one-light scenes print and
write what they always did."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from game import cli
from tests.helpers import TINY
from tests.reference.hand_made_dumps import floor_frame, scene_text, true_lit, write_dump

pytest.importorskip("embreex", reason="verify needs embreex (pip install embreex)")

# The one line per frame of a one-light scene, which outside checks read.
ONE_LIGHT_LINE = re.compile(
    r"^frame_\d{4}: error \d+\.\d{2}% \(\d+ misclassified of \d+ pixels shadowed by the method "
    r"or the reference; \d+ by the reference; \d+ pixels considered, with N\.L > 0\.1 and in "
    r"the light's reach; left out: \d+ out of reach, \d+ where the reference changes with the "
    r"ray offset\)$")
ERROR_KEYS = {"error", "misclassified", "shadowed", "shadowed_either", "considered",
              "left_out_reach", "left_out_offset"}


def verify(capsys, *args) -> tuple[int, list[str], list[str]]:
    code = cli.main([str(a) for a in args])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out.strip().splitlines(), captured.err.strip().splitlines()


def test_each_light_gets_a_line_and_a_wrong_light_a_large_error(capsys, tmp_path):
    position, _ = floor_frame()
    sky = ~np.isfinite(position[..., 0])
    all_lit = np.where(sky, np.nan, 1.0)   # misses the whole shadow of light 1
    for stem in ("frame_0000", "frame_0001"):
        write_dump(tmp_path, scene_text(), [true_lit(position, 0), all_lit], stem=stem)
    code, out, err = verify(capsys, "verify", tmp_path, "--out", tmp_path / "v.json")
    assert code == 0, err
    assert [line.split(":")[0] for line in out] == [
        "frame_0000 light 0 (directional)", "frame_0000 light 1 (point)",
        "frame_0001 light 0 (directional)", "frame_0001 light 1 (point)"]
    assert out[0].endswith(": error 0.00% (0 misclassified of 16 pixels shadowed by the method "
                           "or the reference; 16 by the reference; 399 pixels considered, with "
                           "N.L > 0.1 and in the light's reach; left out: 0 out of reach, 0 "
                           "where the reference changes with the ray offset)")
    assert " error 100.00% (36 misclassified of 36 " in out[1]

    report = json.loads((tmp_path / "v.json").read_text())
    frame = report["frames"][0]
    # The frame's own keys stay light 0's, scored from ``lit``.
    assert frame["frame"] == "frame_0000" and frame["error"] == 0.0 and frame["shadowed"] == 16
    assert [light["light"] for light in frame["lights"]] == [0, 1]
    assert all(set(light) == ERROR_KEYS | {"light"} for light in frame["lights"])
    assert frame["lights"][0]["error"] == 0.0
    assert frame["lights"][1]["error"] == 1.0 and frame["lights"][1]["misclassified"] == 36


def test_pixels_beyond_a_lights_range_are_not_counted(capsys, tmp_path):
    text = scene_text(light_range=7.0)
    position, _ = floor_frame()
    beyond = np.hypot(position[..., 0], position[..., 2]) > np.sqrt(7.0**2 - 6.0**2)
    # Light 1 says "shadowed" beyond its reach, where it lights nothing: not an error.
    bulb = np.where(beyond, 0.0, true_lit(position, 1))
    write_dump(tmp_path, text, [true_lit(position, 0), bulb])
    code, out, err = verify(capsys, "verify", tmp_path, "--out", tmp_path / "v.json")
    assert code == 0, err
    light = json.loads((tmp_path / "v.json").read_text())["frames"][0]["lights"][1]
    assert light["error"] == 0.0
    assert light["considered"] == 399 - int(beyond.sum()) < 399
    assert f"0 misclassified of 36 pixels shadowed by the method or the reference; 36 by the " \
           f"reference; {light['considered']} pixels" in out[1]


def test_a_one_light_scene_prints_one_line_per_frame_as_before(capsys, tmp_path):
    position, _ = floor_frame()
    write_dump(tmp_path, scene_text(point_light=False), [true_lit(position, 0)])
    code, out, err = verify(capsys, "verify", tmp_path, "--out", tmp_path / "v.json")
    assert code == 0, err
    assert len(out) == 1 and ONE_LIGHT_LINE.match(out[0]), out
    frame = json.loads((tmp_path / "v.json").read_text())["frames"][0]
    assert set(frame) == ERROR_KEYS | {"frame", "kind", "lights"} and frame["kind"] == "hard"
    assert frame["lights"] == [{"light": 0, **{k: frame[k] for k in ERROR_KEYS}}]


def test_a_dump_whose_layers_are_not_the_scenes_lights_is_one_line(capsys, tmp_path):
    position, _ = floor_frame()
    write_dump(tmp_path, scene_text(), [true_lit(position, 0)] * 3)
    code, out, err = verify(capsys, "verify", tmp_path)
    assert code == 1 and len(err) == 1, err
    assert "cannot read the dumps" in err[0] and "'lit_lights' holds 3 light" in err[0]


def test_a_captured_scene_of_two_lights_verifies_light_by_light(capsys, tmp_path):
    """End to end: the renderer's own layers, each close to its light's rays."""
    scene = tmp_path / "two.toml"
    sun = '[light]\nkind      = "directional"\ndirection = [-0.4, -1.0, -0.3]\n'
    text = TINY.read_text()
    assert sun in text
    scene.write_text(text.replace(sun, "[" + sun.replace("]\n", "]]\n", 1)
                                  + '\n[[light]]\nkind = "point"\nposition = [2.0, 5.0, 2.0]\n'
                                  "range = 8.0\n"))
    dumps = tmp_path / "dumps"
    assert cli.main(["capture", str(scene), "--size", "96x54", "--dump", "--out",
                     str(dumps)]) == 0
    with np.load(dumps / "frame_0000.npz") as dump:
        assert dump["lit_lights"].shape == (54, 96, 2)
        np.testing.assert_array_equal(dump["lit_lights"][..., 0], dump["lit"])
    capsys.readouterr()
    code, out, err = verify(capsys, "verify", dumps, "--out", tmp_path / "v.json")
    assert code == 0, err
    assert [line.split(":")[0] for line in out] == ["frame_0000 light 0 (directional)",
                                                    "frame_0000 light 1 (point)"]
    lights = json.loads((tmp_path / "v.json").read_text())["frames"][0]["lights"]
    # A small frame has few shadowed pixels, so one edge pixel weighs much (test_cli.py's bound).
    assert all(light["error"] <= 0.2 and light["shadowed"] > 0 for light in lights), lights
