"""Fullscreen passes: ``shaders/fullscreen.vert`` (one triangle over the target, no vertex
buffer) with a fragment shader of the caller's, and the empty vertex array that draws it.

The caller owns both objects and releases them.
"""

from __future__ import annotations

from collections.abc import Mapping

from game.gpu import glsl


def fullscreen_pass(ctx, fragment: str, defines: Mapping[str, object] | None = None):
    """``(program, vao)`` for ``shaders/<fragment>`` built with ``defines``; draw with
    ``vao.render(moderngl.TRIANGLES, vertices=3)``."""
    program = ctx.program(vertex_shader=glsl.build("fullscreen.vert"),
                          fragment_shader=glsl.build(fragment, defines))
    try:
        return program, ctx.vertex_array(program, [])
    except BaseException:
        program.release()
        raise
