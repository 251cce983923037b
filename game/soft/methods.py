"""The soft-shadow methods by name, and the settings of one trace.

The one list of soft method names: the command line, the sweep and the docs read it. A method's
kind is its type. A :class:`TraceMethod` runs in shaders/trace.comp, picked by ``#define METHOD``
(the ``shader_id``); a :class:`RasterMethod` draws depth maps from points of the segment and looks
them up (game/soft/raster.py). Both give the same visibility image.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from game.gpu import blocks
from game.scene.model import Light
from game.soft.grid import CELLS_PER_TRIANGLE, DEFAULT_STRUCTURE, STRUCTURES


@dataclass(frozen=True)
class TraceMethod:
    """A method of the compute tracer: rays (or exact intervals) through the grid."""

    name: str
    shader_id: int
    sampled: bool   # False: exact, its result does not depend on the number of samples
    summary: str


@dataclass(frozen=True)
class RasterMethod:
    """A method that rasterises depth maps from points of the segment instead of tracing."""

    name: str
    summary: str


TRACED_METHODS: dict[str, TraceMethod] = {m.name: m for m in (
    TraceMethod("brute", 0, True, "every sample ray against every triangle (the oracle)"),
    TraceMethod("grid", 1, True, "3D-DDA through the uniform grid, a small per-ray mailbox"),
    TraceMethod("tri-cache", 2, True,
                "a (ray id, flag) word per triangle: the triangle-versus-light-triangle test "
                "runs once per shaded point and triangle"),
    TraceMethod("voxel-cache", 3, True,
                "a ray id and a candidate list per voxel, reset per shaded point: the "
                "per-voxel scheme of \"Some Ideas on Shadow Algorithms\""),
    TraceMethod("analytic", 4, False,
                "exact: the union of the segment intervals that the triangles meeting the "
                "light triangle hide"),
)}
RASTER_METHODS: dict[str, RasterMethod] = {m.name: m for m in (
    RasterMethod("segment-maps",
                 "the mean of depth-map tests from K points along the segment (--maps K); the "
                 "statics' maps are drawn once and cached, the walkers' every frame"),
    RasterMethod("pcss",
                 "percentage-closer soft shadows: one map from the segment's centre, a blocker "
                 "search and a filter along the segment's image, sized by the penumbra"),
)}
METHODS: dict[str, TraceMethod | RasterMethod] = {**TRACED_METHODS, **RASTER_METHODS}
DEFAULT_METHOD = "voxel-cache"
SAMPLED_METHODS = tuple(name for name, m in TRACED_METHODS.items() if m.sampled)


def is_raster(method: str) -> bool:
    """Whether the soft method ``method`` draws depth maps rather than tracing."""
    return isinstance(METHODS[method], RasterMethod)



# The most each tracer parameter may be. The voxel cache, its pool and the mailbox are arrays
# private to each shader invocation, which GL reports no limit for; beyond these the compile
# fails or the driver runs out of stack (llvmpipe), and the per-point reset alone takes
# seconds. The bounds are checked before anything is allocated.
LIMITS = {"samples": 4096, "vc_slots": 1024, "vc_pool": 4096, "mailbox": 64,
          "cells_per_triangle": 64.0, "maps": 64, "map_resolution": 4096}
# The raster methods' defaults (docs/design/raster-soft.md says how they were measured): the
# maps segment-maps draws along the segment, and the side of every raster method's maps.
SEGMENT_MAPS = 16
MAP_RESOLUTION = 1024


@dataclass(frozen=True)
class TraceSettings:
    """How the soft-shadow pass runs."""

    method: str = DEFAULT_METHOD
    samples: int = 32
    cells_per_triangle: float = CELLS_PER_TRIANGLE
    structure: str = DEFAULT_STRUCTURE  # the acceleration structure (game/soft/grid.py)
    vc_slots: int = 64       # voxel-cache: voxels cached per shaded point (a power of two)
    vc_pool: int = 256       # voxel-cache: candidate ids cached per shaded point
    mailbox: int = 8         # triangles remembered per ray
    max_intervals: int = 32  # analytic: disjoint hidden intervals kept per point
    maps: int = SEGMENT_MAPS  # segment-maps: points along the segment, one map each
    map_resolution: int = MAP_RESOLUTION  # raster methods: texels per side of each map

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"unknown trace method {self.method!r}; valid: {', '.join(METHODS)}")
        if self.structure not in STRUCTURES:
            raise ValueError(f"unknown structure {self.structure!r}; valid: "
                             f"{', '.join(STRUCTURES)}")
        if self.samples < 1:
            raise ValueError("samples must be at least 1")
        if self.vc_slots < 1 or self.vc_slots & (self.vc_slots - 1):
            raise ValueError("vc_slots must be a power of two")
        for name, most in LIMITS.items():
            if not 0 < getattr(self, name) <= most:
                raise ValueError(f"{name} must be in (0, {most:g}], got {getattr(self, name)}")

    @property
    def voxel_cache_bytes_per_point(self) -> int:
        """Private memory of one invocation's voxel cache: keys, starts, counts, the pool."""
        return 4 * (3 * self.vc_slots + self.vc_pool + 1)


# Exact hard shadows: one ray per point toward the hard light through the grid (one sample
# toward a point is exact). The ``traced`` hard-shadow method uses these.
EXACT_HARD = TraceSettings(method="grid", samples=1)
# The linear light's exact visibility: the hidden intervals of the segment, merged.
EXACT_SOFT = TraceSettings(method="analytic")


def hard_light(light: Light) -> tuple[int, np.ndarray, np.ndarray]:
    """The tracer's light tuple for the scene's hard light (spot: its cone is shading, not
    visibility, as in the Embree reference)."""
    if light.parallel:
        d = -np.asarray(light.direction, np.float64)
        d = d / np.linalg.norm(d)
        return blocks.TRACE_LIGHT_DIRECTIONAL, d, d
    p = np.asarray(light.position, np.float64)
    return blocks.TRACE_LIGHT_POINT, p, p
