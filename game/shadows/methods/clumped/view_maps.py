"""View-sized clump maps: each clump map's side from what the view needs, in the texels the
fixed maps would take (game/shadows/view_budget.py places them).

A map's need is the texels that give ``view_texels_per_pixel`` across its width where its
clump's shadow is seen; its weight is the need squared times the length of its shadow edges in
widths of the map, counted by the shading pass of earlier frames (:meth:`ViewSizedMaps.served`).
A light among others places its maps in an atlas the lights share (game/shadows/lights.py).
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import NamedTuple

import numpy as np

from game.shadows import crowd
from game.shadows.atlas import Square
from game.shadows.fit import MapFit
from game.shadows.methods.clumped.characters import CharacterMaps
from game.shadows.methods.clumped.clump_maps import ClumpMaps
from game.shadows.methods.clumped.context import LightContext
from game.shadows.plan import MIN_CLUMP_RESOLUTION, MapRecord
from game.shadows.view_budget import ClumpRequest, Placement, ViewBudget, atlas_shape

# The share of a map's weight that its counts before the last frame keep.
EDGE_MEMORY = 0.5

# The clump maps' keys for the view's budget: numbers never given twice in a run, so that no two
# maps, of any light or planner, share one.
_MAP_IDS = itertools.count()


@dataclasses.dataclass(frozen=True)
class ViewIndex:
    """What the view's budget asks of each clump map that does not depend on the view, kept
    while the clumps are: per map its clump, record, key and index within its clump, the centre
    and width it is measured at; per clump its bounding sphere, for its shadow volume."""

    owners: np.ndarray
    records: list[int]
    keys: list[int]
    within: list[int]
    centres: np.ndarray
    widths: np.ndarray
    sphere_centres: np.ndarray
    sphere_radii: np.ndarray


class PlacedRecord(NamedTuple):
    """A clump map's record as placed: the fixed record and the fit and square it was placed
    with, so that an unchanged placement keeps the same record object."""

    source: MapRecord
    fit: MapFit
    square: Square
    record: MapRecord


class PlannedMap(NamedTuple):
    """A clump map of the last plan: its key, its record's index, its side and its need."""

    key: int
    record: int
    side: int
    need: float


class SharedPlacement(NamedTuple):
    """A frame's placements from the lights' shared atlas: every clump map's, the indices of
    those drawn, and the character maps' squares."""

    placements: list[Placement]
    drawn: set[int]
    reserved: list[Square]


class ViewSizedMaps:
    """The clump maps' sides and squares by the view's needs, and the pixel counts they use."""

    def __init__(self, ctx: LightContext, maps: ClumpMaps, characters: CharacterMaps):
        self.ctx = ctx
        self.maps = maps
        self.characters = characters
        self.budget: ViewBudget | None = None  # the light's own atlas
        self.shared_side: int | None = None    # the lights' shared atlas's side, when shared
        self.given: SharedPlacement | None = None
        self.reserved_squares: list[Square] | None = None
        self.edge_widths: dict[int, float] = {}   # per map key, its edges in map widths
        self.counted: dict[int, float] = {}       # per map key, its edges as last counted
        self.asked: np.ndarray | None = None      # the needs of the last view's requests
        self.planned: list[PlannedMap] = []
        self.map_ids: dict[tuple, int] = {}
        self.placed_records: dict[int, PlacedRecord] = {}
        self.index = _empty_index()

    @property
    def reserved_sides(self) -> list[int]:
        """The sides of the squares the character maps keep in a view-sized atlas."""
        return [self.ctx.settings.clump_resolution] * len(self.characters.layers)

    def make_budget(self) -> None:
        """With ``view_resolution``, the light's own atlas, in as many texels as the fixed
        maps would take (their layers, the characters' among them); the character maps keep
        squares of their own. A light among others has none of its own (:meth:`share`)."""
        s = self.ctx.settings
        if not s.view_resolution or self.shared_side is not None:
            return
        texels = (len(self.maps.records) + len(self.characters.layers)) * s.clump_resolution ** 2
        layers, side = atlas_shape(texels, s.clump_resolution, s.max_clump_resolution)
        if self.budget is not None:
            if (self.budget.atlas.layers, self.budget.atlas.resolution) == (layers, side):
                return
            self.maps.members.mark_all()  # every map is placed anew
        self.budget = ViewBudget(layers, side, min(MIN_CLUMP_RESOLUTION, s.clump_resolution),
                                 self.reserved_sides, s.max_map_renders)

    def share(self, side: int) -> None:
        """Place the clump maps in an atlas of ``side``-texel layers that the lights share,
        which hands each frame's placements to :meth:`place_by_view` before the plan."""
        self.shared_side = side
        self.budget = None
        self.maps.members.mark_all()

    def reindex(self) -> None:
        """The :class:`ViewIndex` of the clumps as they are now."""
        maps = self.maps
        owners, centres, widths, keys, records, within = [], [], [], [], [], []
        ids: dict[tuple, int] = {}
        for k, members in enumerate(maps.members.keys):
            centre, radius = maps.spheres[k]
            faces = maps.face_reach.get(k)
            own = tuple(members)
            count = len(maps.of_clump.get(k, []))
            for j, i in enumerate(maps.of_clump.get(k, [])):
                # A map's key is a number that stays while its clump's members do: the budget
                # hashes keys many times a frame, and a tuple of the members is slow to hash.
                ident = self.map_ids.get((own, count, j))
                ids[own, count, j] = ident if ident is not None else next(_MAP_IDS)
                owners.append(k)
                records.append(i)
                keys.append(ids[own, count, j])
                within.append(j)
                centres.append(faces[j][0] if faces else centre)
                widths.append(faces[j][1] if faces else 2.0 * radius)
        self.map_ids = ids
        spheres = [maps.spheres[k] for k in range(len(maps.members.keys))]
        self.index = ViewIndex(
            owners=np.array(owners, int), records=records, keys=keys, within=within,
            centres=np.array(centres, float).reshape(-1, 3), widths=np.array(widths, float),
            sphere_centres=np.array([c for c, _ in spheres], float).reshape(-1, 3),
            sphere_radii=np.array([r for _, r in spheres], float))

    @property
    def counts_pixels(self) -> bool:
        return self.budget is not None or self.shared_side is not None

    @property
    def placed_blind(self) -> bool:
        """Whether its own atlas placed every map of the last plan with no pixels counted."""
        return self.budget is not None and self.budget.blind

    def place_anew(self) -> None:
        if self.budget is not None:
            self.budget.forget()

    def served(self, pixels: np.ndarray) -> None:
        """The length of each clump map's shadow edges in widths of the map, kept by map key
        for the next frames' weights. At the side s it had, a texel spans need / s /
        ``view_texels_per_pixel`` pixels, so that many pixels were counted per pixel of edge;
        the edges' length over the map's width in pixels (the need over the texels per pixel)
        is then the count times s times the texels per pixel squared over the need squared.
        It changes little as the camera comes nearer or goes away, or the frame is resized,
        where the count itself goes with the need. Half of it is kept from the frames before:
        one frame's count moves with every step of the camera and every walker, and maps sized
        by it alone would change side, and be drawn again, as the camera turns. A count that
        repeats the last one exactly (a still camera and scene) is no chance to damp: it is kept
        whole, so that a still view settles in a few counts, where halving the way to it each
        count would move the budget's scale, and the side of some map near a power of two, long
        after."""
        last, tpp = self.edge_widths, self.ctx.settings.view_texels_per_pixel
        widths, counts = {}, {}
        for key, record, side, need in self.planned:
            if need <= 0:  # not in view: nothing was counted
                if key in last:
                    widths[key] = last[key]
                continue
            # One pixel more than counted: a count of a few pixels is mostly chance, and a
            # map that shows none at one side and a few at the next would change side each
            # frame.
            counted = (int(pixels[record]) + 1.0) * side * tpp ** 2 / need ** 2
            counts[key] = counted
            widths[key] = (EDGE_MEMORY * last[key] + (1 - EDGE_MEMORY) * counted
                           if key in last and self.counted.get(key) != counted else counted)
        self.edge_widths, self.counted = widths, counts

    def requests(self, view) -> tuple[list[ClumpRequest], set[int]]:
        """Each clump map as the view's budget sees it, clump by clump, and those that must be
        drawn whatever their side (their clump changed). A map not counted yet has edges one
        width long."""
        ctx, m = self.ctx, self.index
        owners, width = m.owners, m.widths
        n = len(owners)
        need = np.ones(n)  # without a view, alike: the budget's scale sets them
        weight = None
        if view is not None and view.size is not None and n:
            volumes, bounded = crowd.shadow_volumes(m.sphere_centres, m.sphere_radii,
                                                    ctx.light.direction, ctx.kind.eye(ctx.light),
                                                    ctx.ground)
            hidden = (bounded & crowd.outside_view(volumes, view.proj @ view.view))[owners]
            # The density the map's shadow needs where most of it is seen: at its centre's
            # distance (at least half its width), not at its nearest point, which for a clump
            # beside the camera would ask the most texels for a sliver of its shadow.
            depth = np.maximum(-(m.centres @ view.view[2, :3] + view.view[2, 3]),
                               np.maximum(width / 2, 1e-6))
            need = (width * 0.5 * view.size[1] * view.proj[1, 1] / depth
                    * ctx.settings.view_texels_per_pixel)
            need[hidden] = 0.0
            if self.edge_widths:
                edges = np.array([self.edge_widths.get(key, 1.0) for key in m.keys])
                weight = need ** 2 * edges
        self.asked = need
        requests = [ClumpRequest(key=key, maps=1, need=float(need[q]),
                                 weight=None if weight is None else float(weight[q]),
                                 refit=lambda side, k=int(owners[q]), j=m.within[q]:
                                 self.maps.fits_at(k, side)[j:j + 1])
                    for q, key in enumerate(m.keys)]
        dirty = self.maps.members.dirty
        return requests, {q for q in range(n) if owners[q] in dirty}

    def place_by_view(self, placements: list[Placement], drawn: set[int],
                      reserved: list[Square]) -> None:
        """This frame's placements from the shared atlas, for the next plan."""
        self.given = SharedPlacement(placements, drawn, reserved)

    def place(self, maps: list[MapRecord], view) -> tuple[list[int], int] | None:
        """Place this frame's clump maps (their records in ``maps`` replaced): the records
        drawn and the maps whose new side waits; None where the maps are not view-sized."""
        self.reserved_squares = None
        if self.given is not None:  # placed in the lights' shared atlas
            placements, drawn, self.reserved_squares = self.given
            self.given = None
            return sorted(self._placed(maps, placements, drawn)), 0
        if self.budget is not None and view is not None and view.size is not None:
            requests, must = self.requests(view)
            placements, drawn = self.budget.place(requests, must)
            self.reserved_squares = self.budget.reserved
            return sorted(self._placed(maps, placements, drawn)), self.budget.backlog
        return None

    def remember(self, maps: list[MapRecord]) -> None:
        """The needs of this frame's requests, where this plan made them; only counted maps
        need what :meth:`served` reads."""
        asked, self.asked = self.asked, None
        if self.counts_pixels:
            self.planned = [PlannedMap(key, i, maps[i].viewport,
                                       0.0 if asked is None else float(asked[q]))
                            for q, (key, i) in enumerate(zip(self.index.keys, self.index.records,
                                                             strict=True))]

    def _placed(self, maps: list[MapRecord], placements: list[Placement], drawn: set[int]
                ) -> list[int]:
        """Replace the clump maps' records in ``maps`` by their view-sized ``placements`` (in
        the order of :meth:`requests`); returns the records drawn (``drawn`` of them)."""
        records = self.index.records
        made = {}
        for i, placement in zip(records, placements, strict=True):
            square, fit = placement.squares[0], placement.fits[0]
            # The record of a map whose square and fit stay is the last frame's: most stay.
            last = self.placed_records.get(i)
            if (last is not None and last.source is maps[i] and last.fit is fit
                    and last.square == square):
                made[i] = last
                maps[i] = last.record
                continue
            made[i] = PlacedRecord(maps[i], fit, square, dataclasses.replace(
                maps[i], fit=fit, layer=square.layer, viewport=placement.side,
                origin=(square.x, square.y)))
            maps[i] = made[i].record
        self.placed_records = made
        return [records[n] for n in drawn]


def _empty_index() -> ViewIndex:
    return ViewIndex(np.zeros(0, int), [], [], [], np.zeros((0, 3)), np.zeros(0),
                     np.zeros((0, 3)), np.zeros(0))
