"""The wheel's contents: every package of game/, and the shaders and assets mapped into it
(pyproject.toml); .ci/run builds the wheel and runs it from another folder."""

from __future__ import annotations

import tomllib

from game import data
from tests.conftest import ROOT

DATA_PACKAGES = {"game.shaders": "shaders", "game.assets": "assets",
                 "game.assets.models": "assets/models"}


def _setuptools() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def test_every_package_and_data_folder_is_in_the_wheel():
    code = {".".join(init.parent.relative_to(ROOT).parts)
            for init in (ROOT / "game").rglob("__init__.py")}
    assert set(_setuptools()["packages"]) == code | set(DATA_PACKAGES)
    assert _setuptools()["package-dir"] == DATA_PACKAGES


def test_installed_data_wins_over_the_checkout(tmp_path, monkeypatch):
    (tmp_path / "shaders").mkdir()
    monkeypatch.setattr(data, "_PACKAGE", tmp_path)
    assert data.data_dir("shaders") == tmp_path / "shaders"
    assert data.data_dir("assets") == data._CHECKOUT / "assets"  # not installed: the checkout's
