"""The README's example works: its first TOML block is a complete scene that `capture` renders,
and its figure block is the one the report writes (game/bench/report.py)."""

from __future__ import annotations

import re

from game.bench.report import BEGIN, END
from tests.cli.cli_helpers import run
from tests.helpers import ROOT

README = ROOT / "README.md"


def first_toml_block(text: str) -> str:
    match = re.search(r"^```toml\n(.*?)^```", text, re.M | re.S)
    assert match, "README.md has no ```toml block"
    return match.group(1)


def test_the_readme_scene_renders(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(first_toml_block(README.read_text()))
    out = tmp_path / "frames"
    result = run("capture", scene, "--size", "64x36", "--out", out)
    assert result.returncode == 0, result.stderr
    png = out / "frame_0000.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_readme_has_one_figure_block():
    text = README.read_text()
    assert text.count(BEGIN) == 1 and text.count(END) == 1
    assert text.index(BEGIN) < text.index(END)


def test_the_readme_starts_a_user_in_few_words():
    text = README.read_text()
    assert len(text.split()) <= 1500
    # The two commands for a fresh machine come before any other command.
    blocks = re.findall(r"^```bash\n(.*?)^```", text, re.M | re.S)
    assert blocks[:2] == ["pip install -e . && python -m game\n",
                          'pip install -e ".[test]" && python -m pytest\n']
