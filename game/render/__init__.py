"""Rendering: the passes that turn a scene and a shadow plan into frames.

Owns every GL object of a frame, each held by one pass and released explicitly: the scene's
buffers, the frame's blocks, the shadow-map pass and its depth array, the triangle culling, the
shading pass and its target, and the traced lighting (tracer and soft composite). The
:class:`~game.render.renderer.Renderer` orchestrates them. May import ``game.shadows``,
``game.soft``, ``game.scene``, ``game.gpu`` and the base modules.
"""

from game.render.frame import Frame, View
from game.render.renderer import Renderer

__all__ = ["Frame", "Renderer", "View"]
