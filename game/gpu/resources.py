"""What a long run holds: live GL objects, counted by their owners, and the process's memory.

A long capture must keep the number of live GL objects constant and its memory flat. Every owner
counts what it holds (:meth:`game.render.renderer.Renderer.gl_objects`); ``--stats`` records those
counts and the resident set size per frame. :func:`live_gl_names` is the independent check the tests
use: it asks the driver which object names are alive.
"""

from __future__ import annotations

import os

import numpy as np

GL_KINDS = ("Buffer", "Texture", "Framebuffer", "Renderbuffer", "VertexArray", "Program",
            "Shader", "Query", "Sampler")


def rss_bytes() -> int:
    """Resident set size of this process now (Linux /proc; 0 where unavailable)."""
    try:
        with open("/proc/self/statm", "rb") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def attached_shaders(programs) -> int:
    """Shader objects attached to these moderngl programs: moderngl keeps them attached (and
    alive) until the program is released, so an owner counts them with its programs."""
    from OpenGL import GL

    return sum(int(GL.glGetProgramiv(p.glo, GL.GL_ATTACHED_SHADERS)) for p in programs)


def release_targets(ctx, objects) -> None:
    """Release these GL objects (framebuffers and the textures they draw into; None skipped),
    the default framebuffer bound first: moderngl re-binds the framebuffer it used last after
    making one, and must not be left holding a name about to be deleted."""
    objects = [obj for obj in objects if obj is not None]
    if objects:
        ctx.detect_framebuffer(0).use()
    for obj in objects:
        obj.release()


def live_gl_names(gap: int = 1024) -> dict[str, int]:
    """How many names of each GL object kind are alive in the current context.

    Asks the driver (glIsBuffer, glIsTexture, ...), so it counts what really exists, whoever
    made it. Mesa hands out some kinds' names from the lowest free one and others ever upwards
    (a long test run's framebuffers reach tens of thousands), so names are probed up to the
    one the driver would hand out next, and on until ``gap`` names in a row are free.
    """
    from OpenGL import GL

    counts = {}
    for kind in GL_KINDS:
        probe = getattr(GL, f"glIs{kind}")
        top = _next_name(kind)
        alive, name, last = 0, 1, 0
        while name <= top or name <= last + gap:
            if probe(name):
                alive, last = alive + 1, name
            name += 1
        counts[kind] = alive
    return counts


def _next_name(kind: str) -> int:
    """The name the driver hands out next for ``kind`` (made and deleted at once)."""
    from OpenGL import GL

    if kind in ("Program", "Shader"):
        name = GL.glCreateProgram() if kind == "Program" else GL.glCreateShader(
            GL.GL_VERTEX_SHADER)
        getattr(GL, f"glDelete{kind}")(name)
        return int(name)
    plural = {"Query": "Queries"}.get(kind, f"{kind}s")
    made = getattr(GL, f"glGen{plural}")(1)
    name = int(np.ravel(made)[0])  # PyOpenGL gives a scalar or an array of one
    getattr(GL, f"glDelete{plural}")(1, [name])
    return name
