"""What a debug view cannot show in a capture is said in a note."""

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
