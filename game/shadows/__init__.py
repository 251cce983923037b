"""Hard shadows, planned: which maps exist, what each holds, which to draw this frame.

Owns the method protocol (``method``), the plan records (``plan``), fitting one map to one
caster (``fit``), clumping statics (``clumping``), the characters' maps of each frame
(``crowd``), the light-space grid of map lists (``map_grid``), the settings fitted inside the
GL's limits (``budget``), one module per method (``methods/``) and the registry of methods by
name (``registry``). Plans only: no GL objects here. May import ``game.scene``, ``game.gpu``
(constants and limits) and the base modules.
"""
