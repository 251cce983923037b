"""What every pass needs from OpenGL: the context, its limits, timing, the shader preprocessor,
the uniform and storage blocks, fullscreen passes, the depth texture array, and counts of live
GL objects.

Owns no frame state. May import only the base modules (``game.errors``, ``game.data``).
"""
