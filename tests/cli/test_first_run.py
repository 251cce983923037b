"""What a new user meets: answers that cannot be wrong with exit 0, outputs checked before the
work, per-scene output folders, and a command line that helps."""

import json
import shutil

import numpy as np
import pytest

from game import cli
from game.reference.hard import Light, shadow_error
from game.scene import parse_scene
from tests.cli.cli_helpers import assert_one_line_error, in_process, run
from tests.helpers import DEFAULT, LOW_SUN, ROOT, TINY


@pytest.fixture(scope="module")
def tiny_dumps(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny") / "dumps"
    assert cli.main(["capture", str(TINY), "--size", "64x36", "--dump", "--out", str(out)]) == 0
    return out


def test_dumps_record_their_scene(tiny_dumps):
    import hashlib

    with np.load(tiny_dumps / "frame_0000.npz") as dump:
        assert str(dump["scene"]) == str(TINY)
        assert str(dump["scene_sha256"]) == hashlib.sha256(TINY.read_bytes()).hexdigest()


def test_a_one_light_dump_holds_lit_as_lit_lights(tiny_dumps):
    with np.load(tiny_dumps / "frame_0000.npz") as dump:
        assert dump["lit_lights"].shape == (36, 64, 1) and dump["lit_lights"].dtype == np.float32
        np.testing.assert_array_equal(dump["lit_lights"][..., 0], dump["lit"])


def test_verify_without_a_scene_scores_against_the_recorded_one(capsys, tiny_dumps):
    game = in_process(capsys)
    pytest.importorskip("embreex")
    bare, named = game("verify", tiny_dumps), game("verify", tiny_dumps, TINY)
    assert bare.returncode == 0, bare.stderr
    assert bare.stdout == named.stdout
    assert bare.stdout.startswith("frame_0000: error ")


def test_verify_refuses_a_scene_the_dumps_do_not_come_from(capsys, tiny_dumps):
    game = in_process(capsys)
    assert_one_line_error(game("verify", tiny_dumps, DEFAULT), "not the scene these dumps",
                          "tiny.toml")


def test_verify_refuses_a_recorded_scene_that_has_changed(capsys, tmp_path):
    game = in_process(capsys)
    scene = tmp_path / "mine.toml"
    shutil.copy(TINY, scene)
    out = tmp_path / "dumps"
    assert game("capture", scene, "--size", "32x18", "--dump", "--out", out).returncode == 0
    scene.write_text(scene.read_text() + "\n# edited\n")
    assert_one_line_error(game("verify", out), "not the file these dumps were captured from")
    scene.unlink()
    assert_one_line_error(game("verify", out), "not found from here", "SCENE")


def test_verify_of_dumps_that_record_no_scene_needs_one(capsys, tiny_dumps, tmp_path):
    game = in_process(capsys)
    old = tmp_path / "old"
    old.mkdir()
    with np.load(tiny_dumps / "frame_0000.npz") as dump:
        arrays = {k: dump[k] for k in dump.files if k not in ("scene", "scene_sha256")}
    np.savez(old / "frame_0000.npz", **arrays)
    shutil.copy(tiny_dumps / "frame_0000.glb", old / "frame_0000.glb")
    assert_one_line_error(game("verify", old), "do not record their scene")


def test_the_error_lies_in_0_1_whatever_the_method_says():
    rng = np.random.default_rng(3)
    h, w = 20, 30
    position = rng.normal(size=(h, w, 3)).astype(np.float32)
    normal = np.broadcast_to(np.float32([0, 1, 0]), (h, w, 3)).copy()
    light = Light(kind="directional", direction=(0.0, -1.0, 0.0))
    reference = (rng.random((h, w)) > 0.1).astype(np.float32)  # mostly lit
    for method in (np.zeros((h, w)), np.ones((h, w)), 1.0 - reference,
                   rng.random((h, w))):
        err = shadow_error(method.astype(np.float32), reference, position, normal, light)
        assert 0.0 <= err["error"] <= 1.0
        assert err["misclassified"] <= err["shadowed_either"]
    # The method that shadows everything the reference lights is wrong everywhere: 100%.
    err = shadow_error(1.0 - reference, reference, position, normal, light)
    assert err["error"] == 1.0


def test_overlay_is_drawn_on_the_first_frame(capsys, tmp_path):
    game = in_process(capsys)
    from tests.helpers import decode_png

    for name, extra in (("plain", []), ("hud", ["--overlay"])):
        result = game("capture", TINY, "--size", "320x180", "--out", tmp_path / name, *extra)
        assert result.returncode == 0, result.stderr
    plain = decode_png((tmp_path / "plain" / "frame_0000.png").read_bytes())
    hud = decode_png((tmp_path / "hud" / "frame_0000.png").read_bytes())
    assert (plain != hud).any(axis=-1).mean() > 0.05  # the panel covers a good part of it


@pytest.mark.parametrize("args, flag", [
    (["capture", TINY, "--frames", "20", "--stats", "nodir/s.json", "--out", "frames"],
     "--stats"),
    (["trace", TINY, "--stats", "nodir/s.json", "--out", "frames"], "--stats"),
    (["verify", "DUMPS", "--out", "nodir/v.json"], "--out"),
    (["play", TINY, "--frames", "2", "--stats", "nodir/s.json", "--platform", "null"],
     "--stats"),
    (["capture", TINY, "--stats", ".", "--out", "frames"], "--stats"),
])
def test_an_output_that_cannot_be_written_is_refused_before_any_work(capsys, args, flag,
                                                                     tmp_path, tiny_dumps):
    args = [tiny_dumps if a == "DUMPS" else a for a in args]
    # play opens a window: in a child of its own, as a user runs it
    game = run if args[0] == "play" else in_process(capsys)
    result = game(*args, cwd=tmp_path)
    assert result.returncode == 2
    assert_one_line_error(result, flag)
    assert not (tmp_path / "frames").exists()  # nothing was rendered


def test_runs_write_to_a_folder_per_scene_by_default(capsys, tmp_path):
    game = in_process(capsys)
    for command in ("capture", "trace"):
        result = game(command, TINY, "--size", "32x18", "--samples" if command == "trace"
                     else "--frames", "2" if command == "trace" else "1", cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        assert "captures/tiny/" in result.stdout
    assert (tmp_path / "captures" / "tiny" / "frame_0000.png").exists()
    assert [p.name for p in (tmp_path / "captures").iterdir()] == ["tiny"]


@pytest.mark.parametrize("name, folder", [
    ("courtyard", "courtyard"), ("../../etc", "_.._etc-"), ("a/b", "a_b-"), ("a b", "a_b-"),
    ("...", "mine"), ("", "mine"), ("Über", "Über"), ("Äber", "Äber"), ("夜の町", "夜の町"),
])
def test_a_scene_name_becomes_one_safe_folder(name, folder, tmp_path):
    text = TINY.read_text().replace('name = "tiny"', f'name = {json.dumps(name)}')
    scene = parse_scene(text, source=tmp_path / "mine.toml", base_dir=TINY.parent)
    assert scene.folder_name.startswith(folder)
    assert (scene.folder_name == folder) == (not folder.endswith("-"))
    assert "/" not in scene.folder_name and not scene.folder_name.startswith(".")


def test_names_that_change_never_share_a_folder(tmp_path):
    folders = set()
    for name in ("a/b", "a b", "a_b", "a:b"):
        text = TINY.read_text().replace('name = "tiny"', f'name = {json.dumps(name)}')
        folders.add(parse_scene(text, source=tmp_path / "x.toml").folder_name)
    assert len(folders) == 4


def test_bench_takes_a_scene_file_with_its_methods_and_parameters(capsys, tmp_path):
    game = in_process(capsys)
    listed = game("bench", "--scenes", LOW_SUN, "--methods", "clumped,single",
                 "--param", "single_resolution=1024,2048", "--list")
    assert listed.returncode == 0, listed.stderr
    assert listed.stdout.split() == [
        "low_sun|clumped|defaults|320x180", "low_sun|single|defaults|320x180",
        "low_sun|single|single_resolution=1024|320x180",
        "low_sun|single|single_resolution=2048|320x180"]
    result = game("bench", "--scenes", TINY, "--methods", "clumped,single", "--size", "64x36",
                 "--frames", "1", "--warmup", "0", "--error-frames", "1", "--flicker-frames",
                 "0", "--out", tmp_path / "b", "--no-progress")
    assert result.returncode == 0, result.stderr
    rows = (tmp_path / "b" / "bench.csv").read_text().splitlines()
    assert len(rows) == 3 and all(r.startswith("tiny|") for r in rows[1:])
    # Compared like a built-in scene: its Pareto chart and the acceptance figures.
    assert (tmp_path / "b" / "charts" / "pareto_tiny.png").stat().st_size > 0
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert [c["scene"] for c in summary["default_comparisons"]] == ["tiny"]


@pytest.mark.parametrize("args, fragment", [
    (["bench", "--scenes", "nowhere.toml"], "nowhere.toml"),
    (["bench", "--param", "clump_res=512"], "not a swept parameter"),
    (["bench", "--param", "clump_resolution=big"], "is not a whole number"),
    (["bench", "--param", "clumping=diagonal"], "light"),
    (["bench", "--suite", "gpu", "--scenes", "default"], "--scenes"),
])
def test_bad_bench_arguments_get_one_line(capsys, args, fragment):
    game = in_process(capsys)
    assert_one_line_error(game(*args), fragment)


def test_help_shows_the_defaults(capsys):
    game = in_process(capsys)
    text = game("capture", "--help").stdout
    for fragment in ("(default: 1)", "(default: 960x540)", "(default: 30.0)",
                     "captures/<scene name>/", "(default: clumped)"):
        assert fragment in " ".join(text.split()), fragment


def test_a_mistyped_flag_gets_a_suggestion(capsys):
    game = in_process(capsys)
    assert_one_line_error(game("capture", "--frams", "3"), "--frams", "did you mean --frames?")
    assert_one_line_error(game("trace", "--sampels", "3"), "did you mean --samples?")


def test_the_readme_speaks_to_its_reader():
    import re

    text = (ROOT / "README.md").read_text()
    assert not re.search(r"\bseed\b", text, re.I)
    assert not re.search(r"\bissues? \d+|#\d+", text, re.I)


def test_verify_finds_the_recorded_scene_from_another_folder(capsys, tmp_path):
    game = in_process(capsys)
    pytest.importorskip("embreex")
    home = tmp_path / "home"
    home.mkdir()
    shutil.copy(TINY, home / "mine.toml")
    assert game("capture", "mine.toml", "--size", "32x18", "--dump", cwd=home).returncode == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "mine.toml").write_text(DEFAULT.read_text())  # another file of that name
    result = game("verify", home / "captures" / "tiny", cwd=elsewhere)
    assert result.returncode == 0, result.stderr


def test_verify_of_a_folder_mixing_recorded_and_unrecorded_dumps(capsys, tiny_dumps, tmp_path):
    game = in_process(capsys)
    pytest.importorskip("embreex")
    mixed = tmp_path / "mixed"
    shutil.copytree(tiny_dumps, mixed)
    shutil.copy(mixed / "frame_0000.glb", mixed / "frame_0001.glb")
    with np.load(mixed / "frame_0000.npz") as dump:
        np.savez(mixed / "frame_0001.npz", **{k: dump[k] for k in dump.files
                                              if not k.startswith("scene")})
    assert_one_line_error(game("verify", mixed), "1 of the dumps do not record their scene")
    assert game("verify", mixed, TINY).returncode == 0


def test_bench_measures_again_a_scene_file_whose_text_changed(capsys, tmp_path):
    game = in_process(capsys)
    for folder, light in (("a", "-0.4, -1.0, -0.3"), ("b", "0.4, -1.0, 0.3")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "tiny.toml").write_text(
            TINY.read_text().replace("-0.4, -1.0, -0.3", light))
    args = ["--methods", "single", "--size", "32x18", "--frames", "1", "--warmup", "0",
            "--error-frames", "0", "--flicker-frames", "0", "--out", tmp_path / "o",
            "--no-progress"]
    assert game("bench", "--scenes", tmp_path / "a" / "tiny.toml", *args).returncode == 0
    second = game("bench", "--scenes", tmp_path / "b" / "tiny.toml", *args)
    assert second.returncode == 0 and "0 already in" in second.stdout, second.stdout


def test_a_default_output_folder_that_cannot_be_made_is_refused_before_any_work(capsys, tmp_path):
    game = in_process(capsys)
    (tmp_path / "captures").write_text("a file where the folder would go")
    result = game("capture", TINY, "--size", "16x9", cwd=tmp_path)
    assert result.returncode == 2
    assert_one_line_error(result, "output folder captures/tiny")
