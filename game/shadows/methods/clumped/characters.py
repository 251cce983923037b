"""The character maps of one light: layers held for them, and each frame's maps.

Each frame the walkers' maps are sized for the view, skipped where their shadow cannot be seen,
grouped and packed into the layers held for them (game/shadows/crowd.py); fewer layers make the
frame's largest maps coarser, never drop one.
"""

from __future__ import annotations

import numpy as np

from game.shadows import crowd, crowd_runs
from game.shadows.atlas import Square
from game.shadows.fit import MapFit, fit_squares
from game.shadows.method import reached_characters
from game.shadows.methods.clumped.context import LightContext
from game.shadows.methods.clumped.layers import LayerPool
from game.shadows.octahedral import octahedral_encode
from game.shadows.plan import CHARACTER_DENSITY_FLOOR, KIND_CHARACTER, CharacterCounts, MapRecord


def box_corners(points: np.ndarray) -> np.ndarray:
    """The 8 corners of the axis-aligned box of ``points``."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                     for i in (0, 1) for j in (0, 1) for k in (0, 1)])


class CharacterMaps:
    """The layers the character maps share, and the maps of each frame."""

    def __init__(self, ctx: LightContext, pool: LayerPool):
        self.ctx = ctx
        self.pool = pool
        self.layers: list[int] = []
        self.boxes: np.ndarray | None = None  # (n, 8, 3) local bounding-box corners
        self.names: list[str] | None = None   # the characters' names, for the crowd
        self.crowd = crowd.CrowdPlanner(
            min(ctx.settings.min_character_resolution, self.resolution), self.resolution)

    @property
    def resolution(self) -> int:
        """The most texels per side of one character map."""
        s = self.ctx.settings
        return min(s.character_resolution, s.clump_resolution)

    def forget(self) -> None:
        """Characters came or went: their names and boxes are read anew."""
        self.boxes = self.names = None

    def assign(self, clump_layers: int) -> None:
        """Hold enough layers for every character's map at the largest size (the maps are
        packed into them anew each frame), as far as the ``clump_layers`` leave room and at
        most half the layers. The half keeps the cached clump maps, where the method's accuracy
        comes from, from being starved by a worst case that maps sized by need rarely reach."""
        ctx, pool = self.ctx, self.pool
        n = ctx.geom.n_characters
        square = crowd.layer_square(ctx.settings.clump_resolution)
        per_layer = max(1, (square // crowd.pow2_at_least(self.resolution)) ** 2)
        want = -(-n // per_layer)
        if want > pool.limit // 2:
            ctx.note(f"{n} characters' maps at {self.resolution}^2 need {want} shadow-map "
                     f"layers; they get {max(1, pool.limit // 2)}, half the budget's: the "
                     "largest maps of a frame are made coarser when they do not fit")
            want = max(1, pool.limit // 2)
        room = pool.limit - max(1, clump_layers)
        count = min(want, max(room, 1)) if n else 0
        while len(self.layers) > count:
            pool.give(self.layers.pop())
        while len(self.layers) < count:
            self.layers.append(pool.take())
        if count < want:
            ctx.note(f"{n} characters' maps at {self.resolution}^2 need {want} shadow-map "
                     f"layers, {count} are free (GL or memory limit): the largest maps of a "
                     "frame are made coarser when they do not fit")

    def plan(self, models: np.ndarray, view, maps: list[MapRecord], render_dynamic: list[int],
             room: int, clump_density: float, squares: list[Square] | None
             ) -> CharacterCounts | None:
        """Append this frame's character maps to ``maps`` (their indices to
        ``render_dynamic``), at most ``room``; returns their counts for the stats. With
        ``squares`` the layers are squares of an atlas."""
        ctx = self.ctx
        g, s = ctx.geom, ctx.settings
        n = g.n_characters
        if not n:
            return None
        models = np.asarray(models, float)
        visible = reached_characters(g, ctx.light, models)
        if not visible.any():  # a lamp whose range holds no character now
            return CharacterCounts(skipped=n)
        if self.names is None:  # made anew by forget
            self.names = [g.names[g.character_object(i)] for i in range(n)]
            self.crowd.forget(set(self.names))
        # Each character's bounding box, posed: its map's fit and cover need no more.
        if self.boxes is None or len(self.boxes) != n:
            self.boxes = np.stack([box_corners(p) for p in g.character_points])
        placed = (np.einsum("nij,nkj->nki", models[:, :3, :3], self.boxes)
                  + models[:, None, :3, 3])
        centres = models[:, :3, 3]
        radii = np.asarray(g.character_radius, float)
        needed = np.full(n, np.inf)
        if view is not None and view.size is not None and s.character_texels_per_pixel > 0:
            needed = self._needed(view, visible, placed, centres, radii, clump_density)
        shown = np.flatnonzero(visible)
        sizes = self.crowd.sizes([self.names[i] for i in shown.tolist()], needed[shown])
        if ctx.kind.orthographic:
            xy = centres[shown] @ ctx.rotation[:2].T
            r = radii[shown][:, None]
            rects = np.concatenate([xy - r, xy + r], axis=1)
            planned = crowd.group(sizes, rects, self.resolution, room,
                                  merge=s.character_texels_per_pixel > 0)
        else:
            # Around a lamp walkers share a map only where the records run short: the maps
            # are frusta aimed at each caster, whose texels would not line up as a cost
            # model's groups need (docs/design/crowds.md).
            planned = crowd_runs.runs(sizes, lambda: self._seen_from_lamp(placed[shown]),
                                      self.resolution, room)
        shrunk = crowd.pack(planned, len(self.layers), s.clump_resolution)
        covers = fits = None
        if ctx.kind.orthographic:
            xy = placed @ ctx.rotation[:2].T              # (n, 8, 2) across the light
            z = placed @ ctx.rotation[2]                  # (n, 8) along it
            covers = np.concatenate([xy.min(axis=1), xy.max(axis=1)], axis=1)
            fits = self._group_fits(planned, shown, z.min(axis=1), z.max(axis=1))
        drawn = 0
        first = g.character_object(0)
        shown_list = shown.tolist()
        for k, m in enumerate(planned):
            members = [shown_list[j] for j in m.members]
            fit = fits[k] if fits is not None else None
            if fit is None:
                fit = ctx.kind.fit(ctx.light, placed[members].reshape(-1, 3), m.resolution,
                                   ctx.rotation)
            if fit is None:
                continue
            render_dynamic.append(len(maps))
            cover = None
            if covers is not None:  # a slice, not an index array, for a map of one member
                cover = covers[members] if len(members) > 1 else covers[members[0]:members[0] + 1]
            layer, origin = self.layers[m.layer], m.origin
            if squares is not None:  # the layer is a square of an atlas
                square = squares[m.layer]
                layer, origin = square.layer, (square.x + origin[0], square.y + origin[1])
            maps.append(MapRecord(name=f"character_{members[0]}", kind=KIND_CHARACTER, fit=fit,
                                  layer=layer, viewport=m.resolution,
                                  objects=[first + i for i in members],
                                  cover=cover, origin=origin))
            drawn += 1
        return CharacterCounts(drawn, int(n - len(shown)),
                               sum(len(m.members) for m in planned if len(m.members) > 1), shrunk)

    def _seen_from_lamp(self, placed: np.ndarray) -> np.ndarray:
        """Where each walker lies seen from the lamp (n, 2): the centre of the directions its
        posed box ``placed`` (n, 8, 3) spans, in octahedral coordinates with the pole straight
        down, where walkers below a lamp lie unfolded."""
        d = placed.reshape(-1, 3) - np.asarray(self.ctx.light.position, float)
        with np.errstate(invalid="ignore"):  # a corner at the lamp has no direction: NaN
            e = octahedral_encode(np.stack([d[:, 0], d[:, 2], -d[:, 1]], axis=1))
            e = e.reshape(*placed.shape[:2], 2)
            centre = (np.fmin.reduce(e, axis=1) + np.fmax.reduce(e, axis=1)) / 2
        return np.nan_to_num(centre)

    def _needed(self, view, visible: np.ndarray, placed: np.ndarray, centres: np.ndarray,
                radii: np.ndarray, clump_density: float) -> np.ndarray:
        """Per character, the texels its map needs in this view; ``visible`` loses those whose
        shadow the view cannot see."""
        ctx = self.ctx
        s = ctx.settings
        ground = min(ctx.ground, float(placed[..., 1].min()))
        eye = ctx.kind.eye(ctx.light)
        volumes, bounded = crowd.shadow_volumes(centres, radii, ctx.light.direction, eye, ground)
        visible &= ~(bounded & crowd.outside_view(volumes, view.proj @ view.view))
        needed = crowd.texels_needed(volumes, centres, radii, view.view, view.proj,
                                     view.size[1], s.character_texels_per_pixel, eye)
        # A distant walker needs few texels per pixel, but a map much coarser than the clump
        # maps beside it gives its small shadow a blocky outline the statics' do not have: the
        # floor keeps the two of the same order.
        return np.maximum(needed, 2.0 * radii * clump_density * CHARACTER_DENSITY_FLOOR)

    def _group_fits(self, planned: list[crowd.CrowdMap], shown: np.ndarray,
                    z_lo: np.ndarray, z_hi: np.ndarray) -> list[MapFit | None]:
        """Directional light: the fits of the planned maps that carry a square, all at once
        (the members lie within their bounding spheres, so the square holds them all; their
        posed boxes' light-space depths ``z_lo``..``z_hi`` bound the depth); None for the
        others."""
        with_square = [k for k, m in enumerate(planned) if m.square is not None]
        out: list[MapFit | None] = [None] * len(planned)
        if not with_square:
            return out
        members = [planned[k].members for k in with_square]
        order = shown[np.concatenate(members)]
        starts = np.cumsum([0] + [len(m) for m in members[:-1]])
        squares = np.array([planned[k].square for k in with_square], float)
        texels = np.array([np.nan if planned[k].texel is None else planned[k].texel
                           for k in with_square])
        fits = fit_squares(self.ctx.rotation, squares[:, :2], squares[:, 2],
                           np.minimum.reduceat(z_lo[order], starts),
                           np.maximum.reduceat(z_hi[order], starts),
                           np.array([planned[k].resolution for k in with_square]), texels)
        for k, fit in zip(with_square, fits, strict=True):
            out[k] = fit
        return out
