"""The parts a random scene is made of (game/scene/random_scene.py), each a type that writes its
own scene-file table: shapes, placed objects, walkers, the three kinds of light, the camera.

Every number is written with a fixed number of decimals, so that the same draw always gives the
same bytes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

DECIMALS = 3


def num(x: float) -> str:
    """A TOML float with DECIMALS decimals (never ``-0.000``)."""
    return f"{round(float(x), DECIMALS) + 0.0:.{DECIMALS}f}"


def vec(v) -> str:
    return "[" + ", ".join(num(x) for x in v) + "]"


# -- shapes -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Box:
    size: tuple[float, float, float]

    def keys(self) -> list[str]:
        return ['shape    = "box"', f"size     = {vec(self.size)}"]

    def half_height(self) -> float:
        return self.size[1] / 2

    def half_width(self) -> float:
        return max(self.size[0], self.size[2]) / 2


@dataclass(frozen=True)
class Sphere:
    radius: float

    def keys(self) -> list[str]:
        return ['shape    = "sphere"', f"radius   = {num(self.radius)}"]

    def half_height(self) -> float:
        return self.radius

    def half_width(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Round:
    """A cylinder, capsule or cone: a radius and a height along Y, centred on its box."""

    shape: str
    radius: float
    height: float

    def keys(self) -> list[str]:
        return [f'shape    = "{self.shape}"', f"radius   = {num(self.radius)}",
                f"height   = {num(self.height)}"]

    def half_height(self) -> float:
        return self.height / 2

    def half_width(self) -> float:
        return self.radius


@dataclass(frozen=True)
class MeshFile:
    """A mesh file copied into the scene's folder; ``low`` and ``high`` are its bounds in the
    file's own coordinates (the mesh is not centred on its origin)."""

    file: str
    low: tuple[float, float, float]
    high: tuple[float, float, float]

    def keys(self) -> list[str]:
        return ['shape    = "mesh"', f'file     = "{self.file}"']

    @property
    def tallness(self) -> float:
        return self.high[1] - self.low[1]

    def half_width(self) -> float:
        return max(self.high[0] - self.low[0], self.high[2] - self.low[2]) / 2


Shape = Box | Sphere | Round | MeshFile


# -- objects ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Placed:
    """A floor or static: a shape, scaled, rotated and placed (the loader's order)."""

    shape: Shape
    position: tuple[float, float, float]
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: float | tuple[float, float, float] = 1.0
    note: str = ""

    def table(self, kind: str) -> list[str]:
        head = f"[[{kind}]]" + (f"  # {self.note}" if self.note else "")
        lines = [head, *self.shape.keys(), f"position = {vec(self.position)}"]
        if any(self.rotation):
            lines.append(f"rotation = {vec(self.rotation)}")
        if isinstance(self.scale, tuple):
            lines.append(f"scale    = {vec(self.scale)}")
        elif self.scale != 1.0:
            lines.append(f"scale    = {num(self.scale)}")
        return lines


@dataclass(frozen=True)
class Walker:
    """A character: a shape walking a closed path (a single point stands still)."""

    shape: Shape
    path: tuple[tuple[float, float, float], ...]
    speed: float
    phase: float
    scale: float = 1.0

    def table(self) -> list[str]:
        lines = ["[[character]]", *self.shape.keys(),
                 "path     = [" + ", ".join(vec(p) for p in self.path) + "]",
                 f"speed    = {num(self.speed)}", f"phase    = {num(self.phase)}"]
        if self.scale != 1.0:
            lines.append(f"scale    = {num(self.scale)}")
        return lines


# -- lights -------------------------------------------------------------------------------------
def _colour_keys(colour: tuple[float, float, float], intensity: float) -> list[str]:
    return [f"color     = {vec(colour)}", f"intensity = {num(intensity)}"]


@dataclass(frozen=True)
class Sun:
    """A directional light from ``elevation`` degrees above the horizon, from ``azimuth``."""

    elevation: float
    azimuth: float
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def direction(self) -> tuple[float, float, float]:
        e, a = math.radians(self.elevation), math.radians(self.azimuth)
        return (-math.cos(e) * math.sin(a), -math.sin(e), -math.cos(e) * math.cos(a))

    def table(self) -> list[str]:
        return ["[[light]]" + f"  # a sun {self.elevation:.0f} degrees high",
                'kind      = "directional"', f"direction = {vec(self.direction())}",
                *_colour_keys(self.colour, self.intensity)]


@dataclass(frozen=True)
class Spot:
    position: tuple[float, float, float]
    direction: tuple[float, float, float]
    cone: float
    range: float | None = None
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def table(self) -> list[str]:
        lines = ["[[light]]", 'kind      = "spot"', f"position  = {vec(self.position)}",
                 f"direction = {vec(self.direction)}", f"cone      = {num(self.cone)}"]
        if self.range is not None:
            lines.append(f"range     = {num(self.range)}")
        return lines + _colour_keys(self.colour, self.intensity)


@dataclass(frozen=True)
class Point:
    position: tuple[float, float, float]
    range: float | None = None
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def table(self) -> list[str]:
        lines = ["[[light]]", 'kind      = "point"', f"position  = {vec(self.position)}"]
        if self.range is not None:
            lines.append(f"range     = {num(self.range)}")
        return lines + _colour_keys(self.colour, self.intensity)


LightPart = Sun | Spot | Point


@dataclass(frozen=True)
class View:
    """The scene's camera; ``street`` says whether it stands at eye height."""

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    fov: float
    near: float
    far: float
    street: bool

    def table(self) -> list[str]:
        where = "at street level" if self.street else "far above"
        return [f"[camera]  # {where}", f"position = {vec(self.position)}",
                f"target   = {vec(self.target)}", f"fov      = {num(self.fov)}",
                f"near     = {num(self.near)}", f"far      = {num(self.far)}"]
