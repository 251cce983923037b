"""The applications: headless capture and trace, the dumps, every file write (atomic, safe from
Ctrl-C), per-frame stats on disk, and the walkaround window (``window``).

May import ``game.render`` and every layer below it.
"""
