"""Where the program's own data lives: the ``shaders/`` and ``assets/`` folders.

In a source checkout (and an editable install) they sit beside the ``game`` package, at the top
of the repository. A built wheel carries them inside the package, as ``game/shaders`` and
``game/assets`` (pyproject.toml maps the folders there), so an installed program finds them
from any working directory.
"""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
CHECKOUT_DIR = PACKAGE_DIR.parent


def data_dir(name: str) -> Path:
    """The folder ``name`` (``"shaders"`` or ``"assets"``): the wheel's copy, else the
    checkout's."""
    installed = PACKAGE_DIR / name
    return installed if installed.is_dir() else CHECKOUT_DIR / name


SHADER_DIR = data_dir("shaders")
ASSET_DIR = data_dir("assets")
