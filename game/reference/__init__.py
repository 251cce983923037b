"""The independent ground truth: Embree ray casts on the CPU, reading only the dump files.

Owns the hard-shadow reference (``hard``), the linear light's reference (``soft``), the one
scoring function (``score``) and its soft twin (``soft_score``), the points the reference cannot
decide (``offsets``) and the picture of the errors (``error_picture``). Shares no code, no shadow
maps and no GL with the renderer it judges, so a bug in the renderer cannot hide by being
repeated here. May import only the base modules.
"""
