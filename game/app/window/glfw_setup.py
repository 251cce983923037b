"""GLFW for the walkaround: starting it on a display or on the null platform, opening a GL 4.3
core window with an EGL context, and the names of the keys the window listens to."""

from __future__ import annotations

import imgui_bundle  # noqa: F401 - before glfw, so pyGLFW loads the GLFW 3.5 bundled with it

# isort: split
import glfw

from game.errors import GameError

TITLE = "shadowgame"
GL_VERSION = (4, 3)

KEY_NAMES = {
    glfw.KEY_W: "w", glfw.KEY_A: "a", glfw.KEY_S: "s", glfw.KEY_D: "d", glfw.KEY_Q: "q",
    glfw.KEY_E: "e", glfw.KEY_R: "r", glfw.KEY_P: "p", glfw.KEY_M: "m", glfw.KEY_TAB: "tab",
    glfw.KEY_ESCAPE: "escape", glfw.KEY_F1: "f1", glfw.KEY_F12: "f12",
    glfw.KEY_LEFT_SHIFT: "shift", glfw.KEY_RIGHT_SHIFT: "shift",
    glfw.KEY_LEFT: "left", glfw.KEY_RIGHT: "right", glfw.KEY_UP: "up", glfw.KEY_DOWN: "down",
    glfw.KEY_PAGE_UP: "page_up", glfw.KEY_PAGE_DOWN: "page_down", glfw.KEY_L: "l",
    glfw.KEY_LEFT_BRACKET: "[", glfw.KEY_RIGHT_BRACKET: "]",
}


def init_glfw(platform: str = "auto") -> None:
    """Start GLFW on the display (``auto``) or with no display at all (``null``).

    Raises GameError with one line when no display can be opened.
    """
    glfw.ERROR_REPORTING = "ignore"  # failures are reported by the return values below
    if platform == "null":
        glfw.init_hint(glfw.PLATFORM, glfw.PLATFORM_NULL)
    else:
        glfw.init_hint(glfw.PLATFORM, glfw.ANY_PLATFORM)
    if not glfw.init():
        description = glfw.get_error()[1] or b"unknown reason"
        raise GameError(f"cannot open a window ({description.decode(errors='replace')}); "
                        "play --platform null runs it without a display, capture renders "
                        "headless")


def display_available() -> bool:
    """True where GLFW can start on a real display (X11 or Wayland)."""
    try:
        init_glfw("auto")
    except GameError:
        return False
    ok = glfw.get_platform() != glfw.PLATFORM_NULL
    glfw.terminate()
    return ok


def open_window(size: tuple[int, int], platform: str = "auto"):
    """A resizable GL 4.3 core window with an EGL context (PyOpenGL finds its functions through
    EGL, also on X11 and Wayland); GLFW is started for it. One GameError line on failure."""
    init_glfw(platform)
    glfw.window_hint(glfw.CONTEXT_CREATION_API, glfw.EGL_CONTEXT_API)
    glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, GL_VERSION[0])
    glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, GL_VERSION[1])
    glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
    glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
    glfw.window_hint(glfw.RESIZABLE, True)
    window = glfw.create_window(size[0], size[1], TITLE, None, None)
    if not window:
        description = glfw.get_error()[1] or b"unknown reason"
        glfw.terminate()
        raise GameError(f"cannot open a GL {GL_VERSION[0]}.{GL_VERSION[1]} core window "
                        f"({description.decode(errors='replace')})")
    return window
