"""Shared fixtures: one EGL context per session, checked for GL errors around every test, and
the test scenes, loaded afresh. Constants and helpers the test modules share are in
tests/helpers.py; fixtures are found by pytest.
"""

from __future__ import annotations

import pytest

from game.scene import load_scene
from tests.helpers import COURTYARD, TINY


@pytest.fixture(scope="session")
def gl_session():
    """A headless EGL context for the whole run; skips GL tests cleanly where EGL is missing."""
    from game.errors import GameError
    from game.gpu import context

    try:
        ctx = context.create_headless()
    except GameError as exc:
        pytest.skip(f"no usable EGL OpenGL 4.3 context: {exc}")
    yield ctx
    ctx.release()


@pytest.fixture
def ctx(gl_session):
    """The session context, with no GL error before the test and none after it."""
    assert gl_session.error == "GL_NO_ERROR", "a GL error was left by an earlier test"
    yield gl_session
    assert gl_session.error == "GL_NO_ERROR"


@pytest.fixture
def tiny():
    """tests/scenes/tiny.toml, loaded afresh (tests may edit it)."""
    return load_scene(TINY)


@pytest.fixture
def courtyard():
    """The courtyard, loaded afresh (tests may edit it)."""
    return load_scene(COURTYARD)
