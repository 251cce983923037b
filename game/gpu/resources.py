"""What a long run holds: live GL objects, counted by their owners, and the process's memory.

A long capture must keep the number of live GL objects constant and its memory flat. Every owner
counts what it holds (:meth:`game.render.renderer.Renderer.gl_objects`); ``--stats`` records those
counts and the resident set size per frame. :func:`live_gl_names` is the independent check the tests
use: it asks the driver which object names are alive.
"""

from __future__ import annotations

import os

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


def live_gl_names(highest: int = 2048) -> dict[str, int]:
    """How many names of each GL object kind in 1..``highest`` are alive in the current context.

    Asks the driver (glIsBuffer, glIsTexture, ...), so it counts what really exists, whoever
    made it. Mesa hands out the lowest free names, so a small ``highest`` covers a test's objects.
    """
    from OpenGL import GL

    counts = {}
    for kind in GL_KINDS:
        probe = getattr(GL, f"glIs{kind}")
        counts[kind] = sum(1 for name in range(1, highest + 1) if probe(name))
    return counts
