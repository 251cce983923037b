"""Soft shadows of a linear light: traced in an OpenGL compute pass, or rasterised from depth maps.

Owns the soft methods' registry and settings (``methods``), the tracer's acceleration
structures, a uniform or a two-level grid (``grid``), the compute pass (``tracer``), the raster
methods' planning, maps and lookups (``map_frusta``, ``light_maps``, ``raster``), the composite
that lights a frame through a visibility (``composite``), and the window's reduced trace,
upsampled to the frame (``upsample``). May import ``game.scene``, ``game.gpu`` and the base
modules.
"""
