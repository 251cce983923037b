"""GL query objects that can be deleted: moderngl 5.13's Query has no release, so a query made
through it stays alive until the context goes. One object, one name, begun and ended around the
draws it measures."""

from __future__ import annotations

import contextlib
import ctypes

from OpenGL import GL
from OpenGL.raw.GL.VERSION.GL_3_3 import glGetQueryObjectui64v as raw_get_ui64


class GLQuery:
    """A ``GL_TIME_ELAPSED`` or ``GL_SAMPLES_PASSED`` query, owned by whoever made it."""

    def __init__(self, target: int):
        self.target = target
        self.name = int(GL.glGenQueries(1)[0])

    @classmethod
    def time_elapsed(cls) -> GLQuery:
        return cls(GL.GL_TIME_ELAPSED)

    @classmethod
    def samples_passed(cls) -> GLQuery:
        return cls(GL.GL_SAMPLES_PASSED)

    @contextlib.contextmanager
    def measuring(self):
        GL.glBeginQuery(self.target, self.name)
        try:
            yield self
        finally:
            GL.glEndQuery(self.target)

    @property
    def result(self) -> int:
        """The count (samples, or nanoseconds): waits for the draws measured to finish."""
        # The 64-bit form, called raw: PyOpenGL's wrapper has no array type for it, and the
        # 32-bit form clamps at 2^32 - 1 (4.3 s of nanoseconds).
        out = ctypes.c_uint64(0)
        raw_get_ui64(self.name, GL.GL_QUERY_RESULT, ctypes.byref(out))
        return out.value

    def release(self) -> None:
        if self.name:
            GL.glDeleteQueries(1, [self.name])
            self.name = 0
