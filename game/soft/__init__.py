"""Soft shadows of a linear light, traced in an OpenGL compute pass.

Owns the tracer's methods and settings (``methods``), its uniform grid (``grid``), the compute
pass (``tracer``) and the composite that lights a frame through a traced visibility
(``composite``). May import ``game.scene``, ``game.gpu`` and the base modules.
"""
