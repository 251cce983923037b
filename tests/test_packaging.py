"""The wheel's contents: every package of game/, and the shaders and assets mapped into it
(pyproject.toml); .ci/run builds the wheel and runs it from another folder."""

from __future__ import annotations

import tomllib

from game import data
from tests.helpers import ROOT

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
    monkeypatch.setattr(data, "PACKAGE_DIR", tmp_path)
    assert data.data_dir("shaders") == tmp_path / "shaders"
    assert data.data_dir("assets") == data.CHECKOUT_DIR / "assets"  # not installed: the checkout's


def test_every_dependency_is_pinned_to_the_release_line_it_was_tested_with():
    import importlib.metadata
    import re

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = project["dependencies"] + project["optional-dependencies"]["test"]
    for requirement in declared:
        name = re.match(r"[A-Za-z0-9_.-]+", requirement).group(0)
        assert ">=" in requirement and "<" in requirement, f"{requirement}: no upper bound"
        floor = re.search(r">=([0-9.]+)", requirement).group(1)
        installed = importlib.metadata.version(name)
        as_tuple = [tuple(int(x) for x in re.findall(r"\d+", v)[:3]) for v in (floor, installed)]
        assert as_tuple[0] <= as_tuple[1], f"{name} {installed} is below {requirement}"
