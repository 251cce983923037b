"""Shared fixtures: one EGL context per session, checked for GL errors around every test."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCENES = Path(__file__).resolve().parent / "scenes"


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
