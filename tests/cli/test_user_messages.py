"""Messages a user reads: what a debug view cannot show, what is wrong with a folder to verify."""

from tests.cli.cli_helpers import run_main


def test_a_one_frame_cache_view_says_why_it_is_all_red(capsys, tmp_path):
    code, lines = run_main(capsys, "capture", "--debug-view", "cache", "--size", "32x18",
                           "--out", str(tmp_path / "one"))
    assert code == 0
    assert any(line.startswith("note: --debug-view cache: the first frame draws every map")
               for line in lines)
    code, lines = run_main(capsys, "capture", "--debug-view", "cache", "--size", "32x18",
                           "--frames", "2", "--out", str(tmp_path / "two"))
    assert code == 0 and not any("--debug-view cache" in line for line in lines)


def test_verify_says_whether_its_folder_is_missing_a_file_or_empty(capsys, tmp_path):
    (tmp_path / "file").write_text("x")
    (tmp_path / "empty").mkdir()
    for name, fragment in (("missing", "no such folder"), ("file", "not a folder"),
                           ("empty", "no frame_*.npz dumps")):
        code, lines = run_main(capsys, "verify", str(tmp_path / name))
        assert code == 2 and len(lines) == 1 and fragment in lines[0], lines


def test_lights_that_say_the_same_say_it_once(capsys, tmp_path):
    # The night town's sixteen street lamps under csm: one note for all of them, not sixteen.
    from tests.helpers import ROOT

    code, lines = run_main(capsys, "capture", str(ROOT / "assets" / "night_town.toml"),
                           "--method", "csm", "--size", "32x18", "--out", str(tmp_path / "o"))
    cascades = [line for line in lines if "cascades need a directional light" in line]
    assert code == 0 and cascades == [
        "note: lights 1-16: csm: cascades need a directional light; for a point light it draws "
        "the maps of single at cascade_resolution (one frustum, or a cube's faces around the "
        "light)"], lines


def test_a_note_names_its_lights_in_runs():
    from game.shadows.lights import named_lights

    assert [named_lights(k) for k in ([3], [1, 2, 3], [0, 2, 5, 6, 7])] == [
        "light 3", "lights 1-3", "lights 0, 2, 5-7"]
