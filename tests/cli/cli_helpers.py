"""Running the command line from the tests, as a child process or in process, and checking that
an error is one line. Not a test module."""

from __future__ import annotations

import contextlib
import functools
import subprocess
import sys
from pathlib import Path

from game import cli
from tests.helpers import ROOT

# A static mesh entry to append to a scene's text; ``{file}`` is the mesh file.
MESH = '\n[[static]]\nshape = "mesh"\nfile = "{file}"\n'


def run(*args, cwd=None, env=None):
    """``python -m game ARGS`` in a child process."""
    return subprocess.run([sys.executable, "-m", "game", *map(str, args)], cwd=cwd or ROOT,
                          capture_output=True, text=True, timeout=300, env=env)


def assert_one_line_error(result, *fragments):
    """The child failed with one line on stderr, no traceback, holding every fragment."""
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def run_here(capsys, *args, cwd=None) -> subprocess.CompletedProcess:
    """``python -m game ARGS`` in this process, from ``cwd``, reported as :func:`run` reports a
    child: its exit status, standard output and standard error. Quicker than a child by the
    interpreter's start and the imports; where a command must meet a real process (signals, a
    window, the interpreter's own exit), use :func:`run`."""
    capsys.readouterr()
    with contextlib.chdir(cwd or Path.cwd()):
        try:
            code = cli.main([str(a) for a in args])
        except SystemExit as done:   # argparse's --help
            code = done.code or 0
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(list(args), code, out, err)


def in_process(capsys):
    """:func:`run_here` bound to ``capsys``: called as :func:`run` is."""
    return functools.partial(run_here, capsys)


def run_main(capsys, *args) -> tuple[int, list[str]]:
    """``game.cli.main(ARGS)`` in process: its exit status and its stderr lines."""
    code = cli.main([str(a) for a in args])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err.strip().splitlines()


def expect_scene_error(capsys, tmp_path: Path, text: str, line: int | None, key: str,
                       *fragments: str) -> str:
    """Capture the scene ``text``: one error line naming the file, ``line``, ``key`` and every
    fragment, and nothing written. Returns the line."""
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    code, lines = run_main(capsys, "capture", scene, "--size", "32x18", "--out",
                           tmp_path / "out")
    assert code == 1
    assert len(lines) == 1, lines
    message = lines[0]
    assert message.startswith("error: ") and "bad.toml:" in message, message
    if line is not None:
        assert f"bad.toml:{line}:" in message, message
    assert key in message, message
    for fragment in fragments:
        assert fragment in message, message
    assert not (tmp_path / "out").exists()  # nothing written for a bad scene
    return message
