"""Clumping in light space as a partition: square tiles of a directional light's plane, one
cached map each, every static caster drawn into each tile it crosses.

Clumps made by grouping casters overlap in light space wherever their casters do, and a
fragment must then read every map whose rectangle holds it, each after testing its bounds: the
shading pass pays for the overlap on every pixel. Tiles do not overlap. A fragment lies in
exactly one tile, so it reads exactly one static map, and the map grid, aligned to the tiles
(game/shadows/map_grid.py), names that map in one fetch. A caster that crosses a tile's edge is
drawn into both maps; they are cached, so that costs nothing per frame.

Each tile's map covers the tile grown by the shading pass's reach (the bias offsets and a filter
tap, :func:`~game.shadows.plan.shadow_reach`), cut to the casters inside it: a point the bias
moves out of its tile still finds every caster there. Tiles are as wide as one map holds at the
density target, or half as wide where the layers hold that many (:data:`FINER_HALVINGS`), or
wider where the budget's layers cannot hold even the target's.
"""

from __future__ import annotations

import math

import numpy as np

from game.shadows import clumping
from game.shadows.fit import MARGIN_TEXELS, MapFit, fit_squares
from game.shadows.method import bounding_sphere
from game.shadows.methods.clumped.clump_maps import ClumpGeometry, ClumpMaps
from game.shadows.methods.clumped.context import LightContext
from game.shadows.methods.clumped.layers import LayerPool
from game.shadows.methods.clumped.statics import ClumpMembers
from game.shadows.plan import KIND_CLUMP, MapRecord, ShadowSettings, shadow_reach

Tile = tuple[int, int]  # (column, row) on the light plane's lattice
# Tiles are halved this many times below the density target's span where the layers hold them.
# Clumps fitted tightly to their members reached about 1.5 times the target on the shipped
# scenes, and tiles at the target's span would give that accuracy away; finer tiles cost the
# shading pass more memory traffic, so no more than one halving.
FINER_HALVINGS = 1
MAX_PAIRS = 1_000_000  # (tile, unit) pairs listed at most while the tiles are sized


def fits_tiles(settings: ShadowSettings) -> bool:
    """Whether a clump map is wide enough to tile: its margins, the shading pass's reach on
    both sides, take at most half of it. Narrower, a unit grown by the margins would cross
    more tiles however wide they grew."""
    usable = settings.clump_resolution - 2 * MARGIN_TEXELS - 1
    return usable >= 4 * shadow_reach(settings)


def tile_span(ctx: LightContext, resolution: int, scale: float = 1.0) -> float:
    """The side of a tile, in metres of the light plane: what a map of ``resolution`` texels
    holds at the density target with its margins and the reach on both sides, times
    ``scale`` (above 1 where the budget cannot give the target)."""
    s = ctx.settings
    usable = resolution - 2 * MARGIN_TEXELS - 1 - 2 * shadow_reach(s)
    return max(usable, 1.0) / s.texels_per_metre * scale


class TileMembers(ClumpMembers):
    """The tiles of one directional light: each tile's units (a unit may be in several) and
    layer, and which must be drawn. Keeps the interface of :class:`ClumpMembers`, a tile in
    place of a clump."""

    def __init__(self, ctx: LightContext, pool: LayerPool):
        super().__init__(ctx, pool)
        self.tiles: list[Tile] = []
        self.span = 1.0                      # a tile's side in metres
        self.origin = np.zeros(2)            # the lattice's corner, fixed while it stands
        self.unit_rects = np.zeros((0, 4))   # each unit's light-space rectangle

    def tile_rect(self, k: int) -> np.ndarray:
        """Tile ``k``'s square on the light plane (xmin, ymin, xmax, ymax)."""
        lo = self.origin + np.array(self.tiles[k], float) * self.span
        return np.concatenate([lo, lo + self.span])

    def margin(self, side: int, span: float | None = None) -> float:
        """How far a tile's map reaches beyond the tile at ``side`` texels (tiles of side
        ``span``, the current by default): the shading pass's reach in that map's texels."""
        reach = shadow_reach(self.ctx.settings)
        texel = (self.span if span is None else span) / max(
            side - 2 * MARGIN_TEXELS - 1 - 2 * reach, 1.0)
        return reach * texel

    def _cells(self, span: float, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each unit's first and last tile (columns, rows) at side ``span`` from ``origin``,
        its rectangle grown by the map's margin."""
        grow = self.margin(self.ctx.settings.clump_resolution, span)
        rects = self.unit_rects
        lo = np.floor((rects[:, :2] - grow - origin) / span)
        hi = np.floor((rects[:, 2:] + grow - origin) / span)
        return lo, hi

    def _pairs(self, span: float, origin: np.ndarray) -> float:
        """How many (tile, unit) pairs tiles of side ``span`` would hold: counted before any
        is listed, as a density target far above the scene's scale asks for billions."""
        with np.errstate(over="ignore", invalid="ignore"):  # inf: more than any budget holds
            lo, hi = self._cells(span, origin)
            pairs = float(np.prod(hi - lo + 1, axis=1).sum())
        return pairs if math.isfinite(pairs) else math.inf

    def _tiles_at(self, span: float, origin: np.ndarray) -> dict[Tile, list[int]]:
        """Per tile of side ``span`` from ``origin``, the units whose rectangles meet it grown
        by the map's margin."""
        lo, hi = (a.astype(np.int64) for a in self._cells(span, origin))
        out: dict[Tile, list[int]] = {}
        for u, ((x0, y0), (x1, y1)) in enumerate(zip(lo.tolist(), hi.tolist(), strict=True)):
            for y in range(y0, y1 + 1):
                for x in range(x0, x1 + 1):
                    out.setdefault((x, y), []).append(u)
        return out

    def _make_units(self) -> None:
        super()._make_units()
        points = self.units.points
        footprint = self.ctx.kind.footprint(self.ctx.light, [])[0]
        self.unit_rects = (clumping.object_summaries(points, footprint)[0] if points
                           else np.zeros((0, 4)))

    # -- tiling anew ------------------------------------------------------------------------
    def build(self, max_clumps: int) -> None:
        """Tile every unit anew in at most ``max_clumps`` layers' worth of maps."""
        ctx, s = self.ctx, self.ctx.settings
        self.extent_scale, self.short = 1.0, False
        self._make_units()
        for layers in self.layers:
            for layer in layers:
                self.pool.give(layer)
        self.tiles, self.keys, self.layers, self.shared_faces = [], [], [], {}
        if not len(self.unit_rects):
            return
        res = s.clump_resolution
        span = tile_span(ctx, res)
        # The lattice starts where the casters grown by the margin do, so that one tile can
        # hold them all.
        lo = self.unit_rects[:, :2].min(axis=0)
        room = max(1, max_clumps)
        # One tile this wide holds every caster, its margins included (fits_tiles).
        whole = 4.0 * max(float((self.unit_rects[:, 2:].max(axis=0) - lo).max()), 1e-6)
        pairs = self._pairs(span, lo - self.margin(res, span))
        needed = int(min(pairs, MAX_PAIRS + 1))
        while pairs > MAX_PAIRS:  # far more tiles than layers: wider before listing any
            span = min(span * math.sqrt(pairs / MAX_PAIRS), whole)
            pairs = self._pairs(span, lo - self.margin(res, span))
        tiles = self._tiles_at(span, lo - self.margin(res, span))
        needed = len(tiles) if needed <= MAX_PAIRS else needed
        for _ in range(FINER_HALVINGS if needed <= MAX_PAIRS else 0):
            finer = self._tiles_at(span / 2, lo - self.margin(res, span / 2))
            if len(finer) > room:
                break
            span, tiles = span / 2, finer
        while len(tiles) > room:
            # Wider tiles, in as few steps as the count's fall with the width allows.
            span *= max(math.sqrt(len(tiles) / room), 1.05)
            tiles = self._tiles_at(span, lo - self.margin(res, span))
        self.span, self.origin = span, lo - self.margin(res, span)
        if needed > room:
            self.short = True
            ctx.notes.append(
                f"{needed if needed <= MAX_PAIRS else f'over {MAX_PAIRS:,}'} tiles would "
                f"meet {s.texels_per_metre:g} texels/m; {max_clumps} "
                f"layers fit the {s.budget_mib:g} MiB budget and the GL's layers, so texels "
                "are coarser")
        self._assign(tiles)
        self.mark_all()

    def _assign(self, members: dict[Tile, list[int]]) -> None:
        """Tiles in lattice order, each with its units' keys and a layer."""
        keys = self.units.keys
        self.tiles = sorted(members, key=lambda t: (t[1], t[0]))
        self.keys = [[keys[u] for u in members[t]] for t in self.tiles]
        self.layers = [[self.pool.take()] for _ in self.tiles]

    def drop_empty(self) -> None:
        keep = [k for k, keys in enumerate(self.keys) if keys]
        self.tiles = [self.tiles[k] for k in keep]
        super().drop_empty()

    # -- scene edits ------------------------------------------------------------------------
    def update(self, changed: set[str]) -> None:
        """Statics were added, removed or moved (their names in ``changed``): on the same
        lattice, the tiles a changed static leaves or joins are drawn again, and the others
        keep their cached maps. Tiled anew when the tiles no longer fit the layers."""
        before = dict(zip(self.tiles, self.keys, strict=True))
        layers = dict(zip(self.tiles, self.layers, strict=True))
        self._make_units()
        members = self._tiles_at(self.span, self.origin) if len(self.unit_rects) else {}
        if len(members) > self.pool.limit:
            self.build(self.pool.limit)
            return
        keys = self.units.keys
        self.tiles = sorted(members, key=lambda t: (t[1], t[0]))
        self.keys, self.layers, self.dirty = [], [], set()
        for k, tile in enumerate(self.tiles):
            now = [keys[u] for u in members[tile]]
            self.keys.append(now)
            self.layers.append(layers.pop(tile) if tile in layers else [self.pool.take()])
            if now != before.get(tile) or any(key.static in changed for key in now):
                self.dirty.add(k)
        for gone in layers.values():
            for layer in gone:
                self.pool.give(layer)


class TileMaps(ClumpMaps):
    """Per tile its map: the tile grown by the reach, cut to the casters in it."""

    members: TileMembers

    def __init__(self, ctx: LightContext, members: TileMembers):
        super().__init__(ctx, members)
        self.depths: dict[int, tuple[float, float]] = {}  # a tile's casters' light-space z

    def rebuild(self) -> None:
        ctx, m = self.ctx, self.members
        m.drop_empty()
        units = m.units
        index = units.index()
        res = ctx.settings.clump_resolution
        self.clumps, self.records, self.of_clump = [], [], {}
        self.geometry, self.spheres, self.face_reach, self.depths = {}, {}, {}, {}
        # Every unit once, in the order of the first tile that holds it: a tile's units are
        # then mostly neighbours in the index buffer, drawn in few ranges.
        order = list(dict.fromkeys(index[key] for keys in m.keys for key in keys))
        piece_of = {u: p for p, u in enumerate(order)}
        self.pieces = [units.pieces[u] for u in order] + units.beyond
        for k, keys in enumerate(m.keys):
            members = tuple(sorted(index[key] for key in keys))
            points = np.concatenate([units.points[u] for u in members])
            z = points @ ctx.rotation[2]
            self.depths[k] = (float(z.min()), float(z.max()))
            cover = self._cover(k, members, res)
            self.clumps.append(clumping.Clump(members=members,
                                              rect=clumping.union_rect(cover)))
            self.geometry[k] = ClumpGeometry(points, None)
            self.spheres[k] = bounding_sphere(points)
            m.hold_layers(k, 1)
            self.of_clump[k] = [len(self.records)]
            statics = sorted({units.pieces[u][0] for u in members})
            self.records.append(MapRecord(
                name=f"tile_{m.tiles[k][0]}_{m.tiles[k][1]}", kind=KIND_CLUMP,
                fit=self._fit(k, self.clumps[k].rect, res), layer=m.layers[k][0], viewport=res,
                objects=[ctx.geom.static_object(i) for i in statics], cover=cover,
                pieces=[piece_of[u] for u in members], tile=m.tile_rect(k)))
        self.density = self._density_reached()

    def _cover(self, k: int, members: tuple[int, ...], side: int) -> np.ndarray:
        """The light-space rectangles of tile ``k``'s casters, cut to the tile grown by its
        map's margin at ``side`` texels."""
        m = self.members
        grown = m.tile_rect(k) + m.margin(side) * np.array([-1.0, -1.0, 1.0, 1.0])
        cover = m.unit_rects[list(members)].copy()
        cover[:, :2] = np.maximum(cover[:, :2], grown[:2])
        cover[:, 2:] = np.minimum(cover[:, 2:], grown[2:])
        return cover

    def fits_at(self, k: int, side: int) -> list[MapFit]:
        """Tile ``k``'s map at ``side`` texels: its casters' square, cut to the tile and the
        reach at that side."""
        return [self._fit(k, clumping.union_rect(self._cover(k, self.clumps[k].members, side)),
                          side)]

    def _fit(self, k: int, rect: np.ndarray, side: int) -> MapFit:
        """Tile ``k``'s map of ``side`` texels over the light-space rectangle ``rect``."""
        z_lo, z_hi = self.depths[k]
        centre = (rect[:2] + rect[2:]) / 2
        half = max(float(rect[2] - rect[0]), float(rect[3] - rect[1]), 1e-6) / 2
        return fit_squares(self.ctx.rotation, centre[None], np.array([half]),
                           np.array([z_lo]), np.array([z_hi]), np.array([side]),
                           np.array([np.nan]))[0]
