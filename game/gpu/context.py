"""The one place that makes an OpenGL context, headless (EGL) or for a window.

Every other module takes the ``moderngl.Context`` this returns and works the same either way.
"""

from __future__ import annotations

import os

from game.errors import GameError

REQUIRED_GL = (4, 3)  # compute shaders (soft shadows) and storage buffers need 4.3 core

# PyOpenGL must find its function pointers through EGL when there is no X display; it reads this
# before its first import, so set it here, the module every GL path goes through first.
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")


def _check_version(ctx) -> None:
    major, minor = divmod(ctx.version_code, 100)
    minor //= 10
    if (major, minor) < REQUIRED_GL:
        renderer = ctx.info.get("GL_RENDERER", "?")
        version = ctx.info.get("GL_VERSION", "?")
        ctx.release()
        raise GameError(
            f"OpenGL {REQUIRED_GL[0]}.{REQUIRED_GL[1]} core is required, but {renderer} offers "
            f"{version}; use Mesa 20+ (llvmpipe works: apt-get install libgl1-mesa-dri)")


def create_headless():
    """A standalone EGL context (no display needed).

    Raises
    ------
    GameError
        With a one-line hint when EGL or a GL 4.3 driver is missing.
    """
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - dependency missing
        raise GameError(f"moderngl is not installed ({exc}); run pip install -e .") from None
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as exc:  # noqa: BLE001 - glcontext raises plain Exception subclasses
        raise GameError(egl_failure_message(exc)) from None
    _check_version(ctx)
    return ctx


def egl_failure_message(exc: BaseException) -> str:
    """One line for a failed EGL context: what is missing and what to install or use."""
    detail = (str(exc).splitlines() or [type(exc).__name__])[0]
    lowered = detail.lower()
    if "libegl" in lowered or "shared object" in lowered or "cannot open" in lowered:
        return (f"no EGL library found ({detail}); install libegl1 "
                "(Debian/Ubuntu: apt-get install libegl1 libgl1-mesa-dri)")
    return (f"cannot create a headless EGL OpenGL context ({detail}); install a Mesa driver "
            "(apt-get install libgl1-mesa-dri; llvmpipe needs no GPU)")


def wrap_current():
    """Wrap the context a window made current (glfw), checking its version."""
    import moderngl

    ctx = moderngl.create_context()
    _check_version(ctx)
    return ctx


def describe(ctx) -> dict:
    """GL_RENDERER and GL_VERSION, as the stats file records them."""
    return {"renderer": ctx.info["GL_RENDERER"], "version": ctx.info["GL_VERSION"]}


def is_software(ctx) -> bool:
    """True on Mesa's CPU rasterisers, whose GPU timer queries read wrong values."""
    return software_renderer(ctx.info["GL_RENDERER"])


def software_renderer(renderer: str) -> bool:
    """Whether a GL_RENDERER string names one of Mesa's CPU rasterisers."""
    return any(name in renderer.lower() for name in ("llvmpipe", "softpipe", "swrast",
                                                     "lavapipe"))


def unbind_program() -> None:
    """Leave no program current, after compute dispatches.

    On Mesa 22.3 the first program drawn with after a dispatch otherwise outlives its
    glDeleteProgram, with its shaders (tests/render/test_renderer.py counts the GL names a released
    renderer leaves behind).
    """
    from OpenGL import GL

    GL.glUseProgram(0)
