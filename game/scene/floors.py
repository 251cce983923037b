"""Checks of the floor assumption: floors receive shadows but cast none.

"The user can identify the floor(s) and not put it as part of any shadow depth map" holds while a
floor is the lowest thing under it. A floor raised above another object (a platform, a bridge
deck) should shadow it, but no map holds the floor, so every map-based method misses that
shadow. These checks find such floors so capture and bench can warn.
"""

from __future__ import annotations

import numpy as np

FLOOR_CLEARANCE = 1e-3   # share of the floor's height an object may poke below its bottom


def floor_warnings(scene) -> list[str]:
    """Floors that have another object below their top: they hide a shadow (they cast none).

    "Some Ideas on Shadow Algorithms" leaves floors out of every map: "no self-shadowing on the
    floor". That holds while a floor is the lowest thing under it. A platform above a static breaks
    it: the static should be in the platform's shadow but is lit.
    """
    notes = []
    others = [*scene.statics, *scene.floors]
    for floor in scene.floors:
        lo, hi = floor.mesh.bounds
        margin = FLOOR_CLEARANCE * max(hi[1] - lo[1], 1e-9)
        for body in others:
            if body is floor:
                continue
            blo, bhi = body.mesh.bounds
            overlaps = np.all(blo[[0, 2]] < hi[[0, 2]]) and np.all(bhi[[0, 2]] > lo[[0, 2]])
            if overlaps and blo[1] < lo[1] - margin:
                notes.append(f"{floor.name} lies above {body.name}; floors cast no shadow, so "
                             f"{body.name} is lit where the floor shades it (make the raised "
                             f"floor a static to fix)")
                break
    return notes
