"""Shared fixtures and constants: one EGL context per session, checked for GL errors around every
test; the test scenes; the image sizes and the accuracy bound the tests share.

Constants are imported by the test modules (``from tests.conftest import TINY``); fixtures are
found by pytest.
"""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from game.scene import default_scene_path, load_scene, reference_scene_path

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "tests" / "scenes"
ASSETS = ROOT / "assets"
DEFAULT = default_scene_path()        # the built-in town square
COURTYARD = reference_scene_path()     # the reference scene of the benchmark and most tests
TINY = SCENES / "tiny.toml"
POINT = SCENES / "point.toml"
SPOT = SCENES / "spot.toml"
LOW_SUN = SCENES / "low_sun.toml"
POINT_AMONG = SCENES / "point_among.toml"

ACCURACY_SIZE = (320, 180)   # frames scored against Embree
SMALL_SIZE = (160, 90)       # frames compared with each other
MAX_ERROR = 0.05             # the shadow-error bound every method holds on ACCURACY_SCENES
# The scenes the accuracy bound is asserted on, for every method.
ACCURACY_SCENES = {"courtyard": COURTYARD, "square": DEFAULT, "spot": SPOT, "point": POINT,
                   "low_sun": LOW_SUN, "point_among": POINT_AMONG}


def stoppable() -> None:
    """``preexec_fn`` for a child that a test stops with a signal: SIGINT, SIGTERM and SIGHUP at
    their defaults, as in a foreground run. A test run started in the background (``pytest &``)
    passes SIGINT on ignored, and the program rightly keeps ignoring it."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


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
