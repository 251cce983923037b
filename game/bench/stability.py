"""The stability sweep: scenes built to make shadow methods fail ("where methods fail").

Each case is a scene file's text (docs/reference.md, section 1) made from one small layout, varying
one thing: the light's elevation (2 to 90 degrees; exactly 90 is the look-at up-vector singularity),
characters overlapping each other and the statics, a character walking far out of the scene's
bounds, the scene's scale (0.01 to 1000 m), thin casters close to their receivers (peter-panning), a
floor raised above other objects (the floor assumption failing), and more characters than the
shading pass can hold maps for.

The raised floor is detected by ``floors.floor_warnings`` (capture and bench report it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ELEVATIONS = (2.0, 10.0, 30.0, 60.0, 89.0, 90.0)
SCALES = (0.01, 1.0, 1000.0)
# More characters than the uniform block holds map records on llvmpipe (65536 / 128 = 512).
MANY_CHARACTERS = 520


@dataclass(frozen=True)
class Case:
    """One stability scene: the factor it varies, the value, and the scene text."""

    name: str
    factor: str        # elevation | overlap | out-of-bounds | scale | thin | raised-floor | maps
    value: float
    text: str
    # False where the method is not meant to hold the accuracy bar (documented failure modes).
    accuracy_expected: bool = True


def _vec(v) -> str:
    return "[" + ", ".join(f"{float(x):.6g}" for x in v) + "]"


def _sun(elevation_deg: float, azimuth_deg: float = 35.0) -> np.ndarray:
    """The way a sun at this elevation travels (down and across)."""
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    d = np.array([-math.cos(e) * math.cos(a), -math.sin(e), -math.cos(e) * math.sin(a)])
    if elevation_deg == 90.0:
        d = np.array([0.0, -1.0, 0.0])  # exactly vertical: no rounding to save the look-at
    return d


def _layout(scale: float = 1.0, direction=(-0.4, -1.0, -0.3), extra: str = "",
            characters: str | None = None, floor_y: float = -0.1, name: str = "stability",
            camera_far: float = 100.0) -> str:
    """The tiny test layout (tests/scenes/tiny.toml) with the parts each case changes."""
    s = scale
    if characters is None:
        characters = f"""
[[character]]
shape  = "capsule"
radius = {0.3 * s:.6g}
height = {1.8 * s:.6g}
path   = [{_vec(np.array([-3.0, 0.9, -3.0]) * s)}, {_vec(np.array([3.0, 0.9, -3.0]) * s)},
          {_vec(np.array([3.0, 0.9, 2.5]) * s)}, {_vec(np.array([-3.0, 0.9, 2.5]) * s)}]
speed  = {1.5 * s:.6g}
"""
    return f"""name = "{name}"

[camera]
position = {_vec(np.array([0.0, 6.0, 10.0]) * s)}
target   = [0.0, 0.0, 0.0]
fov      = 60.0
near     = {0.1 * s:.6g}
far      = {camera_far * s:.6g}

[light]
kind      = "directional"
direction = {_vec(direction)}

[[floor]]
shape    = "box"
size     = {_vec(np.array([30.0, 0.2, 30.0]) * s)}
position = {_vec(np.array([0.0, floor_y, 0.0]) * s)}

[[static]]
shape    = "box"
size     = {_vec(np.array([1.5, 2.0, 1.0]) * s)}
position = {_vec(np.array([-0.5, 1.0, -0.5]) * s)}

[[static]]
shape    = "sphere"
radius   = {0.7 * s:.6g}
position = {_vec(np.array([1.5, 0.7, 0.8]) * s)}
{extra}{characters}"""


def _capsule(path, radius=0.3, height=1.8, speed=1.5, phase=0.0) -> str:
    pts = ", ".join(_vec(p) for p in path)
    return f"""
[[character]]
shape  = "capsule"
radius = {radius}
height = {height}
path   = [{pts}]
speed  = {speed}
phase  = {phase}
"""


def cases(quick: bool = False) -> list[Case]:
    """Every stability case; ``quick`` keeps one or two values per factor."""
    out: list[Case] = []
    elevations = (2.0, 30.0, 90.0) if quick else ELEVATIONS
    for e in elevations:
        out.append(Case(f"elevation_{e:g}", "elevation", e,
                        _layout(direction=_sun(e), name=f"elevation_{e:g}")))
    loop = [[-3.0, 0.9, -3.0], [3.0, 0.9, -3.0], [3.0, 0.9, 2.5], [-3.0, 0.9, 2.5]]
    overlap = (_capsule(loop) + _capsule(loop, phase=0.1) + _capsule(loop, radius=0.5, phase=0.0)
               # Straight through the box and the sphere: a character overlapping the clumps.
               + _capsule([[-3.0, 0.9, -0.5], [4.0, 0.9, 0.6]], speed=1.0))
    out.append(Case("overlap", "overlap", 4, _layout(characters=overlap, name="overlap")))
    away = _capsule([[2.0, 0.9, 1.5], [200.0, 0.9, 1.5], [200.0, 40.0, -150.0],
                     [2.0, 8.0, 1.5]], speed=60.0)
    out.append(Case("out_of_bounds", "out-of-bounds", 200.0,
                    _layout(characters=away, name="out_of_bounds")))
    for s in (SCALES[0], SCALES[-1]) if quick else SCALES:
        out.append(Case(f"scale_{s:g}", "scale", s, _layout(scale=s, name=f"scale_{s:g}")))
    thin = """
[[static]]                         # a 1 cm plate floating 5 cm above the box's top
shape    = "box"
size     = [1.2, 0.01, 0.8]
position = [-0.5, 2.055, -0.5]

[[static]]                         # a 2 cm wall standing on the floor
shape    = "box"
size     = [3.0, 1.2, 0.02]
position = [-2.5, 0.6, 1.8]
"""
    out.append(Case("thin", "thin", 0.01, _layout(extra=thin, name="thin")))
    raised = """
[[floor]]                          # a platform above static_0: floors cast no shadow
shape    = "box"
size     = [4.0, 0.2, 4.0]
position = [-0.5, 3.0, -0.5]
"""
    out.append(Case("raised_floor", "raised-floor", 3.0,
                    _layout(extra=raised, name="raised_floor"), accuracy_expected=False))
    if not quick:
        ring = ""
        for i in range(MANY_CHARACTERS):
            a = 2 * math.pi * i / MANY_CHARACTERS
            r = 6.0 + 3.0 * (i % 4)
            ring += f"""
[[character]]
shape  = "sphere"
radius = 0.15
path   = [{_vec([r * math.cos(a), 0.3, r * math.sin(a)])}]
"""
        out.append(Case("many_maps", "maps", MANY_CHARACTERS,
                        _layout(characters=ring, name="many_maps")))
    return out
