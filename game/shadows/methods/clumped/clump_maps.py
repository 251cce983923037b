"""The maps of the clumps: their fits, records and what the view's budget measures them by.

Made anew from the clumps' members (game/shadows/methods/clumped/statics.py) whenever they
change; a clump's record keeps its layers, so an unchanged clump's cached map stays valid.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from game.scene.geometry import Piece
from game.shadows import clumping
from game.shadows.fit import MapFit, cube_face_reach, fit_directional
from game.shadows.method import bounding_sphere, caster_spheres
from game.shadows.methods.clumped.context import LightContext
from game.shadows.methods.clumped.statics import ClumpMembers
from game.shadows.plan import KIND_CLUMP, KIND_FALLBACK, MapRecord


class ClumpGeometry(NamedTuple):
    """What a clump's maps are fitted to: its own points, and the points of the long faces it
    shares (orthographic maps: they widen the depth range only)."""

    points: np.ndarray
    depth_points: np.ndarray | None


class ClumpMaps:
    """Per clump, its fits and map records, its sphere and (a cube's) faces' reach."""

    def __init__(self, ctx: LightContext, members: ClumpMembers):
        self.ctx = ctx
        self.members = members
        self.clumps: list[clumping.Clump] = []
        self.records: list[MapRecord] = []          # every clump's maps, clump by clump
        self.of_clump: dict[int, list[int]] = {}    # a clump's records
        self.geometry: dict[int, ClumpGeometry] = {}
        self.spheres: dict[int, tuple[np.ndarray, float]] = {}  # for the view's need
        self.face_reach: dict[int, list[tuple[np.ndarray, float]]] = {}  # a cube's faces'
        self.pieces: list[Piece] = []               # the statics' faces in clump order
        # The clump maps' texels per metre: the target, or coarser where the budget holds them.
        self.density = ctx.settings.texels_per_metre

    def rebuild(self) -> None:
        """Clumps, fits and map records from the members' keys (after any change)."""
        ctx, m = self.ctx, self.members
        units = m.units
        index = units.index()
        footprint = ctx.kind.footprint(ctx.light, [])[0] if ctx.kind.orthographic else None
        m.drop_empty()
        self.clumps, self.records, self.of_clump = [], [], {}
        self.geometry, self.spheres, self.face_reach = {}, {}, {}
        self.pieces = []
        piece_of: dict[int, int] = {}
        member_rects = []
        for keys in m.keys:
            members = tuple(sorted(index[key] for key in keys))
            rects = (clumping.object_summaries([units.points[u] for u in members], footprint)[0]
                     if footprint is not None else None)
            member_rects.append(rects)
            self.clumps.append(clumping.Clump(
                members=members,
                rect=clumping.union_rect(rects) if rects is not None else np.zeros(4)))
            for u in members:
                piece_of[u] = len(self.pieces)
                self.pieces.append(units.pieces[u])
        self.pieces += units.beyond
        long_units = sorted(index[key] for key in units.long if key in index)
        long_corners = (np.stack([footprint(ctx.geom.static_corners(*units.pieces[u]))
                                  for u in long_units])
                        if footprint is not None and long_units else None)
        for k in range(len(self.clumps)):
            self._clump_records(k, member_rects[k], footprint, long_units, long_corners,
                                piece_of)
        self.density = self._density_reached()

    def _clump_records(self, k: int, rects: np.ndarray | None, footprint,
                       long_units: list[int], long_corners: np.ndarray | None,
                       piece_of: dict[int, int]) -> None:
        """Clump ``k``'s fits and records, and the long faces drawn into its map."""
        ctx, m = self.ctx, self.members
        s, points = ctx.settings, m.units.points
        members = self.clumps[k].members
        fallback = long_corners is not None and members[0] in set(long_units)
        extra: list[int] = []
        rect = None
        if long_corners is not None and not fallback:
            # Long faces that cross this map's rectangle are drawn into it too.
            core_points = np.concatenate([points[u] for u in members])
            rect = fit_directional(core_points, ctx.rotation, s.clump_resolution).rect
            meet = clumping.triangles_meet_rects(long_corners, rect[None])[:, 0]
            extra = [u for u, hit in zip(long_units, meet, strict=True) if hit]
        own = tuple(m.keys[k])
        shared = tuple(m.units.keys[u] for u in extra)
        if m.shared_faces.get(own) != shared:
            m.shared_faces[own] = shared
            m.dirty.add(k)
        pieces = [piece_of[u] for u in (*members, *extra)]
        statics = sorted({m.units.pieces[u][0] for u in (*members, *extra)})
        cover = rects
        if extra:  # the long faces' footprints, cut to the map's rectangle
            theirs = clumping.object_summaries([points[u] for u in extra], footprint)[0]
            theirs[:, :2] = np.maximum(theirs[:, :2], rect[:2])
            theirs[:, 2:] = np.minimum(theirs[:, 2:], rect[2:])
            cover = np.concatenate([rects, theirs])
        spheres = None
        if footprint is None:  # a spot or point light
            eye = ctx.kind.eye(ctx.light)
            spheres = np.concatenate([
                caster_spheres(points[u], lambda u=u: ctx.geom.static_corners(*m.units.pieces[u]),
                               eye) for u in (*members, *extra)])
        depth = np.concatenate([points[u] for u in extra]) if extra else None
        core_points = np.concatenate([points[u] for u in members])
        self.geometry[k] = ClumpGeometry(core_points, depth)
        self.spheres[k] = bounding_sphere(core_points)
        fits = self._clump_fits(k, core_points, depth)
        if len(fits) > 1:  # a cube: each face's need follows what it holds
            self.face_reach[k] = cube_face_reach(core_points, ctx.light.position,
                                                 ctx.light.range)
        self.of_clump[k] = []
        for fit, layer in zip(fits, m.layers[k], strict=False):
            self.of_clump[k].append(len(self.records))
            self.records.append(MapRecord(
                name=f"clump_{k}", kind=KIND_FALLBACK if fallback else KIND_CLUMP, fit=fit,
                layer=layer, viewport=s.clump_resolution,
                objects=[ctx.geom.static_object(i) for i in statics], cover=cover,
                spheres=spheres, pieces=pieces))

    def _clump_fits(self, k: int, points: np.ndarray, depth_points: np.ndarray | None
                    ) -> list[MapFit]:
        """The maps of clump ``k``: one fit, or the faces of a cube around a light inside it
        where free layers can hold them; the clump then holds one layer per map."""
        ctx, m = self.ctx, self.members
        res = ctx.settings.clump_resolution
        fits: list[MapFit] = []
        if not ctx.kind.one_frustum(ctx.light, points):
            fits = ctx.kind.clump_fits(ctx.light, points, res, ctx.rotation, cube=True)
            spare = m.pool.spare
            if len(fits) - len(m.layers[k]) > spare:
                ctx.notes.append(f"clump {k} surrounds the light but {spare} free layers "
                                 "cannot hold a cube of maps; its widest frustum is used")
                fits = []
        if not fits:
            fits = ctx.kind.clump_fits(ctx.light, points, res, ctx.rotation, cube=False,
                                       depth_points=depth_points)
        m.hold_layers(k, len(fits))
        return fits

    def fits_at(self, k: int, side: int) -> list[MapFit]:
        """Clump k's maps fitted at ``side`` texels: as many as it has, of the same kind."""
        ctx = self.ctx
        points, depth = self.geometry[k]
        cube = len(self.of_clump.get(k, [])) > 1
        return ctx.kind.clump_fits(ctx.light, points, side, ctx.rotation, cube=cube,
                                   depth_points=depth)

    def coverage_texel(self) -> float | None:
        """The clump maps' texel averaged over what they cover: each map weighs as its span
        squared (texel times side), so that the wide maps, which hold most receivers, count
        most; None without clump maps."""
        maps = [(r.fit.texel, r.viewport) for r in self.records if r.kind == KIND_CLUMP]
        if not maps:
            return None
        texel, side = np.array(maps, float).T
        area = (texel * side) ** 2
        return float((texel * area).sum() / area.sum())

    def _density_reached(self) -> float:
        """The clump maps' texels per metre: the target, or under a directional light the
        median of the maps' own where the budget held them coarser (of the long faces' maps
        where there are no others)."""
        target = self.ctx.settings.texels_per_metre
        texels = ([r.fit.texel for r in self.records if r.kind == KIND_CLUMP]
                  or [r.fit.texel for r in self.records])
        if not self.ctx.kind.orthographic or not texels:
            return target
        return min(target, 1.0 / float(np.median(texels)))
