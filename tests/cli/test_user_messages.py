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
