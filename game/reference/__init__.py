"""The independent ground truth: Embree ray casts on the CPU, reading only the dump files.

Owns the hard-shadow reference (``hard``), the linear light's reference (``soft``) and the one
scoring function (``score``). Shares no code, no shadow maps and no GL with the renderer it
judges, so a bug in the renderer cannot hide by being repeated here. May import only the base
modules.
"""
