"""What clumps are made of: the statics' parts, split where wider than one map.

Each unit has a key, (static name, serial), stable while its static is unchanged, so that a
clump keeps its members, and its cached map, across edits of other statics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from game.scene.geometry import Piece
from game.shadows import clumping
from game.shadows.method import bounding_sphere, reached_statics
from game.shadows.methods.clumped.context import LightContext


class UnitKey(NamedTuple):
    """A unit's name: its static's name and its serial among that static's units."""

    static: str
    serial: int


@dataclass
class StaticUnits:
    """The units of the statics a light reaches, and the faces it does not."""

    pieces: list[Piece]              # (static index, faces) of each unit
    points: list[np.ndarray]         # each unit's points
    keys: list[UnitKey]
    beyond: list[Piece]              # faces beyond the light's range: in no clump
    # Single faces wider than one map at the target (directional lights): drawn into each clump
    # map they cross, and owned by a few coarse maps of their own.
    long: set[UnitKey]

    def index(self) -> dict[UnitKey, int]:
        return {key: u for u, key in enumerate(self.keys)}


def max_extent(ctx: LightContext, per_metre: float, extent_scale: float,
               as_fine_as_baselines: bool = True) -> float:
    """The widest a clump may be, in footprint units: one map at the density target, times
    ``extent_scale`` where the budget cannot meet the target.

    A lamp's target holds at the casters' typical distance, but the baselines' maps are fixed
    in angle, and nearer the lamp they are finer than the target asks. A lamp's clump is held
    no wider than keeps its map, in angle, as fine as theirs (``as_fine_as_baselines``;
    ``single_resolution`` is the side the baselines give this light: game/shadows/lights.py)."""
    s = ctx.settings
    extent = (clumping.max_extent_for_density(s.clump_resolution, s.texels_per_metre)
              * per_metre * extent_scale)
    finest = ctx.kind.finest_extent(ctx.light, s.clump_resolution, s.single_resolution)
    if finest is None or not as_fine_as_baselines:
        return extent
    return min(extent, finest * extent_scale)


def make_units(ctx: LightContext, extent_scale: float) -> StaticUnits:
    """The statics' parts (game/scene/parts.py), a part wider than one map at the density
    target split further (:func:`clumping.split_wide`)."""
    g, light = ctx.geom, ctx.light
    names = [g.names[g.static_object(i)] for i in range(g.n_statics)]
    # The faces beyond the light's range are in no clump, but the index buffer's order
    # (static_pieces) must still hold every face.
    reached = set(reached_statics(g, light))
    beyond = [(i, np.arange(len(g.triangles[g.static_object(i)])))
              for i in range(g.n_statics) if i not in reached]
    parts: list[tuple[int, np.ndarray]] = []
    points: list[np.ndarray] = []
    for i in sorted(reached):
        labels = g.static_parts[i]
        order = np.argsort(labels, kind="stable")
        split = np.split(order, np.flatnonzero(np.diff(labels[order])) + 1)
        for faces in split:
            parts.append((i, faces))
            points.append(g.static_points[i] if len(split) == 1 else g.static_corners(i, faces))
    footprint, per_metre = ctx.kind.footprint(light, points)
    # Parts are split at the density target alone: held to the baselines' angle, a wall
    # beside a lamp would split into pieces that each take a map, where one cube around the
    # lamp holds the whole wall.
    limit = max_extent(ctx, per_metre, extent_scale, as_fine_as_baselines=False)
    rects = clumping.object_summaries(points, footprint)[0] if points else np.zeros((0, 4))
    units = StaticUnits([], [], [], beyond, set())
    serial = dict.fromkeys(range(g.n_statics), 0)
    ranged = light.range is not None
    for (i, faces), part_points, rect in zip(parts, points, rects, strict=True):
        pieces = [faces]
        if clumping.rect_extent(rect) > limit and len(faces) > 1:
            corners = g.static_corners(i, faces).reshape(-1, 3, 3)
            pieces = clumping.split_wide(corners, faces, footprint, limit)
        for piece in pieces:
            unit_points = part_points if len(pieces) == 1 else g.static_corners(i, piece)
            if ranged and not light.reaches(*bounding_sphere(unit_points)):
                units.beyond.append((i, piece))  # a part of a large static out of range
                continue
            units.pieces.append((i, piece))
            units.points.append(unit_points)
            units.keys.append(UnitKey(names[i], serial[i]))
            serial[i] += 1
    # A single face wider than one map at the target (a roof's edge, a long wall's side)
    # cannot be split. Clumped alone it would take a coarse map of its own and spread every map
    # it joined; instead it is drawn into each clump map it crosses, at that map's texels, and
    # owned by a few coarse maps of such faces for the ground between clumps (directional
    # lights, where a map's footprint is a rectangle of the common plane).
    if ctx.kind.orthographic and units.points:
        unit_rects = clumping.object_summaries(units.points, footprint)[0]
        units.long = {units.keys[u] for u, rect in enumerate(unit_rects)
                      if len(units.pieces[u][1]) == 1 and clumping.rect_extent(rect) > limit}
    return units
