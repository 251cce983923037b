"""The walkaround window: glfw input, the free-fly camera, the timing overlay and its controls,
the lights tab and the light keys, the layer viewer, and presenting the frame in the window.

May import ``game.app`` and every layer below it.
"""
