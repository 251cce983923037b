"""Soft shadows of a linear light, traced in an OpenGL compute pass.

Owns the tracer's methods and settings (``methods``), its acceleration structures, a uniform or
a two-level grid (``grid``), the compute pass (``tracer``), the composite that lights a frame
through a traced visibility (``composite``), and the window's reduced trace, upsampled to the
frame (``upsample``). May import ``game.scene``, ``game.gpu`` and the base modules.
"""
