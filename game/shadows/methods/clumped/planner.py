"""``clumped``: the multi-map method of "Some Ideas on Shadow Algorithms".

Cached maps of clumps of statics and tight character maps drawn every frame, in one depth
array; floors are in no map. This facade holds one light's parts, a concept each:

- :mod:`.layers`: the pool of array layers and the limit the budget sets;
- :mod:`.units`, :mod:`.statics`: what the clumps are made of, and the clump policy;
- :mod:`.tiles`: clumping in light space under a directional light, as a partition of its
  plane into tiles, so that a fragment reads one static map;
- :mod:`.clump_maps`, :mod:`.characters`: the clumps' maps, and the walkers' of each frame;
- :mod:`.view_maps`: the clump maps sized by the view (``view_resolution``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows import clumping
from game.shadows.atlas import Square
from game.shadows.method import ShadowMethod, SharesBudget, ViewSized
from game.shadows.methods.clumped.characters import CharacterMaps
from game.shadows.methods.clumped.clump_maps import ClumpMaps
from game.shadows.methods.clumped.context import LightContext
from game.shadows.methods.clumped.layers import LayerPool
from game.shadows.methods.clumped.statics import ClumpMembers
from game.shadows.methods.clumped.tiles import TileMaps, TileMembers, fits_tiles
from game.shadows.methods.clumped.view_maps import ViewSizedMaps
from game.shadows.plan import (
    MIN_SHORT_RESOLUTION,
    MapRecord,
    ShadowPlan,
    ShadowSettings,
    budget_of,
    layer_bytes,
)
from game.shadows.view_budget import ClumpRequest, Placement


def _in_context(name: str) -> property:
    """An attribute of the method that is the field ``name`` of its :class:`LightContext`."""
    return property(lambda self: getattr(self.ctx, name),
                    lambda self, value: setattr(self.ctx, name, value))


class ClumpedShadows(ShadowMethod, SharesBudget, ViewSized):
    """The multi-map method: cached clump maps plus per-character maps in one array.

    The clumps follow the texel-density target within the layers the budget and the GL allow;
    past them the clumps grow coarser and ``notes`` says so. Character maps get coarser or are
    merged when layers or records run short (degrade, never drop a shadow). A static edited at
    run time re-renders only the clump maps it leaves or joins (:meth:`update_statics`).
    """

    name = "clumped"
    summary = ("one cached map per clump of statics and tight character maps sized for the view, "
               "in one depth array")
    resolution_fields = ("clump_resolution", "character_resolution")
    parameters = ("clumping", "clump_count", "texels_per_metre", "clump_resolution",
                  "character_resolution", "character_texels_per_pixel", "view_resolution",
                  "max_clump_resolution")
    budgeted = True

    @classmethod
    def min_layers(cls, settings: ShadowSettings, n_characters: int) -> int:
        return 1 + min(n_characters, 1)  # one clump and one (shared) character map

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int, max_maps: int | None = None):
        settings = dataclasses.replace(settings, budget_mib=budget_of(settings))
        if settings.view_resolution:
            # The atlas's squares have power-of-two sides: the fixed maps whose texels it holds
            # too, no larger than asked, so that it keeps to the budget.
            side = settings.clump_resolution
            settings = dataclasses.replace(settings, clump_resolution=1 << (side.bit_length() - 1))
        self.ctx = LightContext.of(geom, light, settings)
        super().__init__(geom, light, settings, max_layers, max_maps)
        self.pool, self.members, self.maps, self.characters, self.view = self._parts()
        side = settings.clump_resolution
        if (self.members.short and settings.clump_count is None
                and side // 2 >= MIN_SHORT_RESOLUTION):
            self._halve(side)
        if (self.members.short and settings.clump_count is None
                and not self.ctx.kind.orthographic):
            self._one_clump_if_finer()
        if self.members.short and self.ctx.kind.orthographic:
            # How much coarser. Seen from far away the texels may be under a pixel wide on
            # screen, no collapse (game/shadows/collapse.py), while the error that their size
            # and bias bring along every shadow's edge is not small.
            self.note(f"its clump maps hold {self.maps.density:.3g} texels/m (their median), "
                      f"where {settings.texels_per_metre:g} were asked")

    def _one_clump_if_finer(self) -> None:
        """A lamp short of layers: its statics as one clump, in the maps the baselines give
        the light (a cube around a point light, a spot's map over its cone) at the largest
        side that fits, up to the baselines', where those maps' texels are finer than the
        clumps'. By default the light's share holds the baselines' maps
        (game/shadows/lights.py).

        Seen from a lamp, clumps lie behind one another, and clumps merged to fit the layers
        take maps that overlap on the same directions, where a cube spends every texel on a
        direction of its own. Not under parallel light, whose clumps tile its plane."""
        texel = self.maps.coverage_texel()
        if texel is None:
            return
        saved = self._saved()
        settings, notes, _ = saved
        side = min(settings.single_resolution, settings.max_clump_resolution)
        while side >= MIN_SHORT_RESOLUTION:
            self._replan(dataclasses.replace(settings, clump_resolution=side, clump_count=1),
                         list(notes))
            if not self.members.short:
                one = self.maps.coverage_texel()
                if one is not None and one < texel:
                    self.note(f"its clumps, merged to fit the layers, are coarser than the "
                              f"baselines' maps ({self.ctx.kind.engine_maps}) at {side}^2: "
                              "the statics take those")
                    return
                break  # a smaller side is coarser still
            side //= 2
        self._restore(saved)

    def _halve(self, side: int) -> None:
        """Short of layers, maps of a quarter of the texels, four times as many, hug the statics
        closer and leave less of the budget on empty ground between them. Not where a cube
        around the light stays: its six faces hold the receivers round the light whatever the
        side, and halving would quarter their texels to give the other clumps maps that, four
        times as many, together hold no more texels."""
        saved, cube = self._saved(), self.cube_side
        settings = self.settings
        self._replan(dataclasses.replace(settings, clump_resolution=side // 2), [])
        if cube is not None and self.cube_side is not None:
            self._restore(saved)
            return
        self.note(f"the clumps at {settings.texels_per_metre:g} texels/m do not fit the "
                  f"{settings.budget_mib:g} MiB budget in maps of {side}^2: the clump "
                  f"maps are {side // 2}^2, four times as many")

    def _saved(self) -> tuple:
        """What :meth:`_replan` replaces, for :meth:`_restore`: the settings, the notes and the
        parts."""
        return (self.settings, list(self.notes),
                (self.pool, self.members, self.maps, self.characters, self.view))

    def _replan(self, settings: ShadowSettings, notes: list[str]) -> None:
        """The parts planned anew from ``settings``, after ``notes``."""
        self.settings, self.notes = settings, notes
        self.pool, self.members, self.maps, self.characters, self.view = self._parts()

    def _restore(self, saved: tuple) -> None:
        self.settings, self.notes, parts = saved
        self.pool, self.members, self.maps, self.characters, self.view = parts

    def _parts(self) -> tuple[LayerPool, ClumpMembers, ClumpMaps, CharacterMaps, ViewSizedMaps]:
        """The parts planned from the settings: the character maps' layers first, then the
        clumps in what is left."""
        s, ctx = self.settings, self.ctx
        pool = LayerPool(s.budget_mib, s.clump_resolution, self.max_layers)
        if tiled(ctx):
            members: ClumpMembers = TileMembers(ctx, pool)
            maps: ClumpMaps = TileMaps(ctx, members)
        else:
            members = ClumpMembers(ctx, pool)
            maps = ClumpMaps(ctx, members)
        characters = CharacterMaps(ctx, pool)
        view = ViewSizedMaps(ctx, maps, characters)
        characters.assign(clump_layers=0)
        members.build(max(1, pool.limit - len(characters.layers)))
        maps.rebuild()
        view.reindex()
        view.make_budget()
        return pool, members, maps, characters, view

    # What the method protocol holds lives in the context, so that the parts read the same.
    geom = _in_context("geom")
    settings = _in_context("settings")
    notes = _in_context("notes")
    light = property(lambda self: self.ctx.light,
                     lambda self, light: self.ctx.set_light(light))  # its kind and rotation too

    # -- what the array holds -----------------------------------------------------------------
    @property
    def static_maps(self) -> list[MapRecord]:
        return self.maps.records

    @property
    def clumps(self) -> list[clumping.Clump]:
        return self.maps.clumps

    @property
    def cube_side(self) -> int | None:
        """Texels per side of the faces of the cube around the light (a point light's clumps
        that surround it share one), or None where no clump takes a cube."""
        for maps in self.maps.of_clump.values():
            if len(maps) > 1:
                return self.maps.records[maps[0]].viewport
        return None

    @property
    def meets_density(self) -> bool:
        return not self.members.short

    @property
    def layer_limit(self) -> int:
        return self.pool.limit

    @property
    def max_clumps(self) -> int:
        return max(1, self.pool.limit - len(self.characters.layers))

    @property
    def resolution(self) -> int:
        if self.view.shared_side is not None:
            return self.view.shared_side
        if self.view.budget is not None:
            return self.view.budget.atlas.resolution
        return self.settings.clump_resolution

    @property
    def layers(self) -> int:
        if self.view.budget is not None:
            return self.view.budget.atlas.layers
        return self.pool.fixed

    @property
    def reserved_layers(self) -> int:
        # A light moved or edited may clump anew into more or fewer layers, up to the limit.
        if self.view.budget is not None:
            return self.layers
        return max(self.layers, self.pool.limit)

    @property
    def memory_mib(self) -> float:
        # The fixed maps' layers: view-sized maps take as many texels.
        return self.pool.fixed * layer_bytes(self.settings.clump_resolution) / 2**20

    # -- the budget shared between lights -----------------------------------------------------
    @property
    def wants_memory(self) -> bool:
        # Short of the budget's layers, not the GL's, and without room for one more clump's
        # maps: a lamp whose clumps all surround it ends in one cube, whatever it is given.
        pool = self.pool
        return (self.members.short and pool.budget_layers < self.max_layers
                and pool.fixed + self.ctx.kind.max_maps_per_caster > pool.limit)

    def limit_memory(self, mib: float) -> None:
        self.settings = dataclasses.replace(self.settings, budget_mib=mib)
        self.pool.hold_to(mib, self.settings.clump_resolution)

    # -- view-sized maps ------------------------------------------------------------------------
    @property
    def fixed_texels(self) -> int:
        return max(self.pool.fixed, self.pool.limit) * self.settings.clump_resolution ** 2

    def share_view_budget(self, side: int) -> None:
        self.view.share(side)

    def view_requests(self, view) -> tuple[list[ClumpRequest], set[int]]:
        return self.view.requests(view)

    def place_by_view(self, placements: list[Placement], drawn: set[int],
                      reserved: list[Square]) -> None:
        self.view.place_by_view(placements, drawn, reserved)

    counts_pixels = property(lambda self: self.view.counts_pixels)
    placed_blind = property(lambda self: self.view.placed_blind)
    reserved_sides = property(lambda self: self.view.reserved_sides)

    def served(self, pixels: np.ndarray) -> None:
        self.view.served(pixels)

    def place_anew(self) -> None:
        self.view.place_anew()

    # -- changes --------------------------------------------------------------------------------
    def set_light(self, light: Light) -> None:
        """A new light invalidates every clump map (and light-space clumps themselves)."""
        self.light = light
        if tiled(self.ctx) != isinstance(self.members, TileMembers):
            self.pool, self.members, self.maps, self.characters, self.view = self._parts()
            return
        self.members.build(self.max_clumps)
        self._clumps_changed()

    def _clumps_changed(self) -> None:
        self.maps.rebuild()
        self.view.reindex()
        self.view.make_budget()

    def update_statics(self, geom: PackedGeometry, changed: set[str]) -> list[int]:
        """Statics were added, removed or moved (their names in ``changed``): only the clumps
        they leave or join are drawn again (:meth:`ClumpMembers.update`), whose indices this
        returns."""
        self.geom = geom
        self.ctx.set_light(self.light)
        self.members.update(changed)
        self._clumps_changed()
        return sorted(self.members.dirty)

    def update_characters(self, geom: PackedGeometry) -> None:
        """Characters were added or removed: free and hand out their layers."""
        self.geom = geom
        self.characters.forget()
        self.characters.assign(sum(len(ls) for ls in self.members.layers))
        if self.view.budget is not None:  # the characters' squares change: place all anew
            self.view.budget = None
            self.view.make_budget()
            self.members.mark_all()

    def mark_rendered_lost(self) -> None:
        """The array was re-created (resized): every cached layer must be drawn again."""
        self.members.mark_all()

    # -- a frame --------------------------------------------------------------------------------
    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        """The maps for this frame; ``models`` are the characters' (n, 4, 4) matrices."""
        maps = list(self.maps.records)
        placed = self.view.place(maps, view)
        if placed is None:
            render_static = sorted(i for k in self.members.dirty
                                   for i in self.maps.of_clump.get(k, []))
            backlog = 0
        else:
            render_static, backlog = placed
        render_dynamic: list[int] = []
        counts = self.characters.plan(models, view, maps, render_dynamic,
                                      self.max_maps - len(maps), self.maps.density,
                                      self.view.reserved_squares)
        self.members.dirty = set()
        self.view.remember(maps)
        return ShadowPlan(resolution=self.resolution, maps=maps,
                          render_static=render_static, render_dynamic=render_dynamic,
                          static_pieces=self.maps.pieces, characters=counts,
                          backlog=backlog)


def tiled(ctx: LightContext) -> bool:
    """Whether the statics are tiled (:mod:`.tiles`): clumping in light space under a
    directional light, without a clump count asked for (tiles cannot be counted out), and
    with maps of fixed texels (view-sized maps place clumps by the view's need instead) wide
    enough for a tile and its margins."""
    s = ctx.settings
    return (ctx.kind.orthographic and s.clumping == "light" and s.clump_count is None
            and not s.view_resolution and fits_tiles(s))
