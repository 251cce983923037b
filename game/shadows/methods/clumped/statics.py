"""The clump policy: which statics share a cached map, and how clumps follow scene edits.

How to group points into clumps is game/shadows/clumping.py's (world or light space, a width
limit or a count); this module decides what is grouped and how many clumps a light can afford:
the units of game/shadows/methods/clumped/units.py at the texel-density target, fewer and wider
clumps where the budget's layers cannot hold them, a point light's clump around it as a cube's
six maps, and a static added, moved or removed at run time joining the nearest clump.
"""

from __future__ import annotations

import math

import numpy as np

from game.shadows import clumping
from game.shadows.fit import CUBE_FACES
from game.shadows.methods.clumped.context import LightContext
from game.shadows.methods.clumped.layers import LayerPool
from game.shadows.methods.clumped.units import StaticUnits, UnitKey, make_units, max_extent

LAMP_SEARCH = 4  # clumps at the target counted past a lamp's layers, in multiples of them


class ClumpMembers:
    """The clumps of one light: each clump's unit keys and layers, and which must be drawn."""

    def __init__(self, ctx: LightContext, pool: LayerPool):
        self.ctx = ctx
        self.pool = pool
        # Parts are split for maps this many times wider than the density target's (above 1
        # where the budget cannot meet the target), and whether it cannot.
        self.extent_scale = 1.0
        self.short = False
        self.units = StaticUnits([], [], [], [], set())
        self.keys: list[list[UnitKey]] = []   # member units' keys per clump
        self.layers: list[list[int]] = []     # a clump's layers: one, or cube faces
        self.dirty: set[int] = set()          # clumps whose maps must be drawn
        self.shared_faces: dict[tuple, tuple] = {}  # a clump's own keys -> long faces it shares
        self._frusta: dict[tuple[int, ...], bool] = {}  # units -> one frustum holds them

    def mark_all(self) -> None:
        """Every clump's maps are drawn again."""
        self.dirty = set(range(len(self.keys)))

    def _make_units(self) -> None:
        self.units = make_units(self.ctx, self.extent_scale)
        self._frusta = {}

    def _max_extent(self, per_metre: float) -> float:
        return max_extent(self.ctx, per_metre, self.extent_scale)

    # -- clumping anew ----------------------------------------------------------------------
    def build(self, max_clumps: int) -> None:
        """Clump every unit anew, in at most ``max_clumps`` layers' worth of maps."""
        ctx, s = self.ctx, self.ctx.settings
        self.extent_scale, self.short = 1.0, False
        self._make_units()
        count = s.clump_count
        if count is not None and count > max_clumps:
            ctx.notes.append(f"{count} clumps asked, {max_clumps} fit the layer budget")
            count = max_clumps
        # Around a lamp the clumps short of the budget are made anew by count
        # (:meth:`_fewer_clumps`), so the clumps at the target are only counted, and only as
        # far as shows that they cannot fit: a lamp whose cone spans a whole level could ask for
        # tens of thousands, minutes of splitting for a number in a note.
        search = (None if count is not None or ctx.kind.orthographic
                  else LAMP_SEARCH * max(1, max_clumps))
        clumps, core, long_clumps, footprint, summaries = self._clumps_at_target(count, search)
        room = max(1, max_clumps - len(long_clumps))
        layers = self._layers_for(clumps, core)
        if layers > room:
            needed = layers + len(long_clumps)
            if search is not None and len(clumps) >= search:
                # Counted only so far: every clump takes a layer at least.
                needed = f"at least {search + len(long_clumps)}"
            self.short = True
            ctx.notes.append(
                f"{needed} clumps would meet {s.texels_per_metre:g} "
                f"texels/m; {max_clumps} layers fit the {s.budget_mib:g} MiB budget and "
                "the GL's layers, so texels are coarser")
            if count is None and ctx.kind.orthographic:
                # The parts were split for the target's maps, which the budget cannot give:
                # split them for the maps it can (a clump count goes as the inverse square of
                # the clumps' width). Parts cut finer serve no clump, and more single faces
                # would count as long ones, drawn into every map they cross. Not around a
                # spot or point light, where a clump may take one layer or a cube's six: there
                # the count does not follow the width, and a lamp moved a little would clump
                # anew into a different number of maps.
                self.extent_scale = math.sqrt(needed / max_clumps)
                self._make_units()
                clumps, core, long_clumps, footprint, summaries = self._clumps_at_target(None)
                room = max(1, max_clumps - len(long_clumps))
            clumps = self._fewer_clumps(core, footprint, summaries, room)
        for layers in self.layers:
            for layer in layers:
                self.pool.give(layer)
        self.keys = [[self.units.keys[core[m]] for m in c.members] for c in clumps]
        self.keys += long_clumps
        self.layers = [[self.pool.take()] for _ in self.keys]
        self.shared_faces = {}
        self.mark_all()

    def _fewer_clumps(self, core: list[int], footprint, summaries,
                      room: int) -> list[clumping.Clump]:
        """The most clumps of the ``core`` units whose maps fit ``room`` layers: a clump around
        a point light takes a cube's six, so fewer clumps until the maps of all of them fit.

        The count is searched by halves: merging clumps can turn several one-map clumps into
        one cube of six, so the layers over the room say little of how many clumps to drop:
        dropping one clump per layer over can take a point light among many statics from 46
        clumps in 101 layers to a single cube, a sixth of the layers it was given. The core
        units' ``summaries`` are :meth:`_clumps_at_target`'s."""
        points = [self.units.points[u] for u in core]

        def clumps_of(count: int) -> tuple[list[clumping.Clump], int]:
            clumps = self._one_cube(clumping.make_clumps(
                points, footprint, self.ctx.settings.clumping, 0.0, count,
                summaries=summaries), core)
            return clumps, self._layers_for(clumps, core)

        clumps, layers = clumps_of(room)
        if layers <= room:
            return clumps
        fits: list[clumping.Clump] | None = None
        low, high = 1, room - 1   # the largest count that fits lies in [low, high]
        while low <= high:
            mid = (low + high) // 2
            clumps, layers = clumps_of(mid)
            if layers <= room:
                fits, low = clumps, mid + 1
            else:
                high = mid - 1
        return fits if fits is not None else clumps_of(1)[0]

    def _one_cube(self, clumps: list[clumping.Clump], core: list[int]) -> list[clumping.Clump]:
        """The clumps, those that take a cube around the light merged into one: every cube's
        faces span the same angles, so two cubes give no finer texels than one, in twice the
        layers."""
        ctx = self.ctx
        if ctx.kind.orthographic:
            return clumps
        cubes = [c for c in clumps if not self._one_frustum(c, core)]
        if len(cubes) < 2:
            return clumps
        merged = clumping.Clump(tuple(sorted(m for c in cubes for m in c.members)),
                                clumping.union_rect(np.array([c.rect for c in cubes])))
        return [c for c in clumps if all(c is not cube for cube in cubes)] + [merged]

    def _clumps_at_target(self, count: int | None, search: int | None = None):
        """The units' clumps at the density target (or ``count`` of them; no more than
        ``search`` where given), the core units they are made of, the long faces' clumps, the
        light's footprint function, and the core units' summaries (None without any)."""
        ctx, units = self.ctx, self.units
        footprint, per_metre = ctx.kind.footprint(ctx.light, units.points)
        long_keys = [k for k in units.keys if k in units.long]
        core = [u for u, k in enumerate(units.keys) if k not in units.long]
        long_clumps = self.long_clumps(long_keys, footprint)
        if count is not None:
            count = max(1, min(count, len(core)) - len(long_clumps)) if core else None
        if not core:
            return [], core, long_clumps, footprint, None
        points = [units.points[u] for u in core]
        summaries = clumping.object_summaries(points, footprint)
        clumps = clumping.make_clumps(points, footprint, ctx.settings.clumping,
                                      self._max_extent(per_metre), count, search, summaries)
        return clumps, core, long_clumps, footprint, summaries

    def _layers_for(self, clumps: list[clumping.Clump], core: list[int]) -> int:
        """The layers these clumps' maps take: one each, six for a clump around the light."""
        ctx = self.ctx
        if ctx.kind.orthographic:
            return len(clumps)
        return sum(1 if self._one_frustum(c, core) else CUBE_FACES for c in clumps)

    def _one_frustum(self, clump: clumping.Clump, core: list[int]) -> bool:
        """Whether one frustum from the light holds ``clump`` (of the ``core`` units), asked
        once per member set: the search for fewer clumps meets the same clumps at many
        counts."""
        key = tuple(core[m] for m in clump.members)
        if key not in self._frusta:
            self._frusta[key] = self.ctx.kind.one_frustum(self.ctx.light, np.concatenate(
                [self.units.points[u] for u in key]))
        return self._frusta[key]

    def long_clumps(self, keys: list[UnitKey], footprint) -> list[list[UnitKey]]:
        """The long faces ``keys`` in clumps of their own: few, each about as wide as two of
        the longest, since they only shadow what lies between the other clumps."""
        if not keys:
            return []
        index = self.units.index()
        points = [self.units.points[index[key]] for key in keys]
        widest = float(max(clumping.rect_extent(r)
                           for r in clumping.object_summaries(points, footprint)[0]))
        return [[keys[m] for m in c.members]
                for c in clumping.make_clumps(points, footprint, self.ctx.settings.clumping,
                                              2.0 * widest)]

    def drop_empty(self) -> None:
        """Clumps left without members go, and give back their layers."""
        keep = [k for k, keys in enumerate(self.keys) if keys]
        for k in range(len(self.keys)):
            if k not in keep:
                for layer in self.layers[k]:
                    self.pool.give(layer)
        old_dirty = self.dirty
        self.keys = [self.keys[k] for k in keep]
        self.layers = [self.layers[k] for k in keep]
        self.dirty = {new for new, k in enumerate(keep) if k in old_dirty}

    def hold_layers(self, k: int, maps: int) -> None:
        """Take or give back layers so that clump ``k`` holds one per map (at least one)."""
        layers = self.layers[k]
        before = list(layers)
        while len(layers) < max(1, maps):
            layers.append(self.pool.take())
        while len(layers) > max(1, maps):
            self.pool.give(layers.pop())
        if layers != before:
            self.dirty.add(k)

    # -- scene edits ------------------------------------------------------------------------
    def update(self, changed: set[str]) -> None:
        """Statics were added, removed or moved (their names in ``changed``; the context holds
        the new geometry).

        Every part of a changed static leaves its clump (that clump's map is re-rendered: its
        old place). A static that still exists comes back: where it fits one map at the
        density target, each of its parts joins the clump whose footprint overlaps its own the
        most, or the nearest one (re-rendered too: its new place); the parts of a larger one (a
        level in one file) are clumped anew among themselves, in clumps of their own. Other
        clumps keep their cached maps.
        """
        self._make_units()
        index = self.units.index()
        for k, keys in enumerate(self.keys):
            kept = [key for key in keys if key in index and key.static not in changed]
            if len(kept) != len(keys):
                self.keys[k] = kept
                self.dirty.add(k)
        self.drop_empty()
        footprint, per_metre = self.ctx.kind.footprint(self.ctx.light, self.units.points)
        by_static: dict[str, list[UnitKey]] = {}
        for key in self.units.keys:
            if key.static in changed:
                by_static.setdefault(key.static, []).append(key)
        arrivals = []
        for keys in by_static.values():
            core = [key for key in keys if key not in self.units.long]
            own = clumping.make_clumps([self.units.points[index[key]] for key in core],
                                       footprint, self.ctx.settings.clumping,
                                       self._max_extent(per_metre)) if core else []
            if len(own) == 1 and len(core) == len(keys):  # it fits one map: it joins the others
                arrivals += keys
                continue
            groups = [[core[m] for m in clump.members] for clump in own]
            groups += self.long_clumps([key for key in keys if key in self.units.long],
                                       footprint)
            for group in groups:
                self._new_clump(group)
        if arrivals:
            self._join_nearest(arrivals, footprint, index)

    def _new_clump(self, keys: list[UnitKey]) -> int:
        self.keys.append(keys)
        self.layers.append([self.pool.take()])
        self.dirty.add(len(self.keys) - 1)
        return len(self.keys) - 1

    def _join_nearest(self, arrivals: list[UnitKey], footprint, index: dict[UnitKey, int]
                      ) -> None:
        """Each arriving unit joins the clump its footprint overlaps most, or the nearest."""
        points, long = self.units.points, self.units.long
        # Candidates: the clumps of other faces, not the fallback maps of long faces.
        rects = [clumping.object_summaries([points[index[key]] for key in keys], footprint)[0]
                 if keys and keys[0] not in long else np.zeros((0, 4))
                 for keys in self.keys]
        own_rects = clumping.object_summaries([points[index[key]] for key in arrivals],
                                              footprint)[0]
        for key, own in zip(arrivals, own_rects, strict=True):
            k = nearest_clump(own, rects)
            if k is None:
                k = self._new_clump([])
                rects.append(np.zeros((0, 4)))
            self.keys[k].append(key)
            rects[k] = np.vstack([rects[k], own[None]])
            self.dirty.add(k)


def nearest_clump(rect: np.ndarray, clump_rects: list[np.ndarray]) -> int | None:
    """The clump overlapping ``rect`` most, else the one whose footprint is nearest."""
    best, best_key = None, None
    for k, rects in enumerate(clump_rects):
        if not len(rects):
            continue
        u = clumping.union_rect(rects)
        w = min(u[2], rect[2]) - max(u[0], rect[0])
        h = min(u[3], rect[3]) - max(u[1], rect[1])
        overlap = max(w, 0.0) * max(h, 0.0)
        gap = math.hypot(max(-w, 0.0), max(-h, 0.0))
        key = (-overlap, gap)
        if best_key is None or key < best_key:
            best, best_key = k, key
    return best
