"""Every light's shadow maps as one plan: one method per light, one depth array, one budget.

Each light gets its own planner of the chosen method (its own clumps, its own character maps:
light-space clumping and the maps' fits depend on the light). The shadow memory budget is
shared: each light first gets the layers its kind cannot do without (a point light's cube and a
layer of character maps), and the rest goes by how much of the scene the light reaches (a
directional light all of it, a lamp the disc of its range). The baselines give a light with a
range smaller maps than the sun, as engines do: ``lamp_resolution`` texels for a lamp that
lights a corner, more for one whose range spans more of the scene (:func:`lamp_side`).

Their plans are laid side by side in one depth array: light k's layers follow light k - 1's, and
the layers of lights whose maps are smaller than the array's layers are packed into the squares
of shared array layers. With view-sized maps (``view_resolution``) the lights' clump maps
instead share one atlas, each map's side from what the view needs whichever light casts it
(game/shadows/view_budget.py). :class:`LightSpan` says where each light's maps are, for the
shading pass's light records.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows import registry
from game.shadows.budget import fit_baseline_memory
from game.shadows.cube_sides import baselines_memory, coarse_cube_notes, finer_cubes, lamp_side
from game.shadows.light_kinds import kind_of
from game.shadows.method import ShadowMethod, SharesBudget, ViewSized, caster_spheres
from game.shadows.plan import (
    MIN_CLUMP_RESOLUTION,
    CharacterCounts,
    ShadowPlan,
    ShadowSettings,
    budget_of,
    layer_bytes,
)
from game.shadows.view_budget import ViewBudget, atlas_shape

MIN_LAMP_RESOLUTION = 128  # the smallest clump maps a lamp's share may make


@dataclass(frozen=True)
class ArrayShape:
    """What the depth array must hold for a frame's plan."""

    resolution: int  # texels per side of its layers
    layers: int


@dataclass(frozen=True)
class LightSpan:
    """Where one light's maps are in the frame's plan."""

    first_map: int
    map_count: int
    first_layer: int


def min_layers(light: Light) -> int:
    """The clump layers a light cannot do without: a cube around a point light, one map for
    others, and one layer that the character maps share."""
    return kind_of(light).max_maps_per_caster + 1


def reach_weight(light: Light, scene_radius: float) -> float:
    """How much of the scene a light reaches: 1 for a light without a range, else the share of
    the scene's disc that its range covers."""
    if light.range is None or light.position is None:
        return 1.0
    return min(1.0, (light.range / max(scene_radius, 1e-6)) ** 2)


def budget_shares(lights: list[Light], total_mib: float, resolution: int,
                  scene_radius: float) -> tuple[list[float], list[int]]:
    """Each light's share of the memory budget in MiB, and the side of its clump maps (see the
    module's docstring): where the lights' floors take more than half the budget, the lamps'
    clump maps are halved (down to :data:`MIN_LAMP_RESOLUTION`) until they do not, the other
    lights' kept, so that the share by reach keeps half the budget."""
    if len(lights) == 1:
        return [total_mib], [resolution]
    sides = [resolution] * len(lights)

    def floors() -> list[float]:
        return [min_layers(light) * layer_bytes(side) / 2**20
                for light, side in zip(lights, sides, strict=True)]

    lamps = [k for k, light in enumerate(lights) if light.range is not None]
    while sum(floors()) > total_mib / 2 and lamps and sides[lamps[0]] > MIN_LAMP_RESOLUTION:
        for k in lamps:
            sides[k] //= 2
    spare = total_mib - sum(floors())
    if spare <= 0:
        return [total_mib / len(lights)] * len(lights), sides
    weights = [reach_weight(light, scene_radius) for light in lights]
    return [f + spare * w / sum(weights) for f, w in zip(floors(), weights, strict=True)], sides


class LightShadows:
    """The shadow planners of every light of a scene. Holds no GL object."""

    def __init__(self, geom: PackedGeometry, lights: list[Light], settings: ShadowSettings,
                 max_layers: int, max_maps: int):
        # The baselines' maps are sized anew where their array is over the baselines' budget;
        # each time every side halves, so this ends.
        # A budgeted method's lights are planned again within less where their layers, laid
        # out in whole array layers, take more than they were given: each time the shared
        # budget shrinks by what they took past it, at least a layer, so this ends; it also
        # stops where what the lights were given did not shrink (what a light is owed does
        # not).
        budget_notes: list[str] = []
        # By default no light gets less than the baselines' maps of it take (the comparison
        # is then never between a light's clumps and maps it had no memory for); a budget
        # given is held to.
        budgeted = registry.method_class(settings.method).budgeted
        self._radius = scene_radius(geom)  # over every static vertex: once, not per re-plan
        owed = (baselines_memory(lights, settings, self._radius, geom.n_characters > 0)
                if settings.budget_mib is None and budgeted else [0.0] * len(lights))
        settings = dataclasses.replace(settings, budget_mib=budget_of(settings))
        asked, packed, last = None, False, float("inf")
        # The other lights' clumps are drawn as whole statics (plan): their casters' spheres
        # are the whole statics'.
        self._geom = geom
        self._eyes = [kind_of(light).eye(light) for light in lights]
        self._whole: dict[tuple[int, tuple[int, ...]], np.ndarray] = {}
        while True:
            self._make(geom, lights, settings, max_layers, max_maps, owed)
            fitted = fit_baseline_memory(settings, self._resolution(), self._places()[1])
            if fitted is not None:
                settings, note = fitted
                budget_notes.append(note)
                continue
            asked = self.budget_mib if asked is None else asked
            over = self.array_mib - asked
            step = max(over, layer_bytes(self._resolution()) / 2**20)
            if (not budgeted or over <= 0 or settings.budget_mib <= step
                    or self.budget_mib >= last):
                break
            last = self.budget_mib
            settings = dataclasses.replace(settings, budget_mib=settings.budget_mib - step)
            packed = True
        if packed:
            budget_notes.append(
                f"the lights' maps need {self.array_mib:.4g} MiB of array layers at the fewest, "
                f"more than the {asked:.4g} MiB they were given" if self.array_mib > asked else
                f"the lights' maps, laid out in whole layers of the array, took more than the "
                f"{asked:.4g} MiB they were given; they are planned within "
                f"{self.budget_mib:.4g} MiB")
        self._notes[:0] = budget_notes

    def _make(self, geom: PackedGeometry, lights: list[Light], settings: ShadowSettings,
              max_layers: int, max_maps: int, owed: list[float]) -> None:
        n = len(lights)
        radius = self._radius
        shares, sides = budget_shares(lights, settings.budget_mib, settings.clump_resolution,
                                      radius)
        shares = [max(share, o) for share, o in zip(shares, owed, strict=True)]
        self.budget_mib = sum(shares)  # the memory the lights' plans were given

        def create(k: int, share: float) -> ShadowMethod:
            light, side = lights[k], sides[k]
            own = dataclasses.replace(
                settings, budget_mib=share, clump_resolution=side,
                character_resolution=min(settings.character_resolution, side))
            if light.range is not None:
                lamp = lamp_side(light, settings, radius)
                own = dataclasses.replace(
                    own, single_resolution=min(settings.single_resolution, lamp),
                    cascade_resolution=min(settings.cascade_resolution, lamp))
            return registry.create(geom, light, own, max(1, max_layers // n),
                                   max(1, max_maps // n))

        self.methods: list[ShadowMethod] = [create(k, share) for k, share in enumerate(shares)]
        finer_cubes(self.methods, shares, sides, create, settings, radius)
        self._notes: list[str] = []
        if n > 1:
            self._pass_on_what_is_left(shares, create, radius, self.budget_mib)
        self._notes += coarse_cube_notes(self.methods, settings, radius)
        self._bases: list[tuple[int, int]] | None = None
        # With view-sized maps, one atlas for every light's clump maps, so that texels go where
        # the view needs them whichever light casts there.
        self.view_budget: ViewBudget | None = None
        self._view_shape: tuple = ()
        if (n > 1 and settings.view_resolution
                and all(isinstance(m, ViewSized) for m in self.methods)):
            self._share_view_budget()

    def _share_view_budget(self) -> None:
        """One atlas in the texels that the lights' fixed maps keep (their limits' layers),
        of layers of the largest power-of-two side up to ``max_clump_resolution`` that hold
        them with at most a quarter more; the lights' character maps keep squares of their
        own. Every clump map is placed, and drawn, anew."""
        methods, s = self.methods, self.methods[0].settings
        texels = sum(m.fixed_texels for m in methods)
        sides = [m.settings.clump_resolution for m in methods]
        layers, side = atlas_shape(texels, max(sides), s.max_clump_resolution)
        self._view_shape = self._view_wants()
        smallest = min(MIN_CLUMP_RESOLUTION, *sides)
        self.view_budget = ViewBudget(layers, side, smallest,
                                      [edge for m in methods for edge in m.reserved_sides],
                                      s.max_map_renders)
        for method in methods:
            method.share_view_budget(side)

    def _view_wants(self) -> tuple:
        """What the shared atlas is made for: every light's fixed texels and character
        squares."""
        return tuple((m.fixed_texels, tuple(m.reserved_sides)) for m in self.methods)

    def _check_view_budget(self) -> None:
        """Make the shared atlas anew where characters or clumps came or went: asked before
        the array is sized (:meth:`prepare`)."""
        if self.view_budget is not None and self._view_wants() != self._view_shape:
            self._share_view_budget()

    def _place_by_view(self, view) -> None:
        """Every light's clump maps placed by this view's needs in the one atlas: the
        placements and the character maps' squares handed to each light's planner."""
        requests, must, spans = [], set(), []
        for k, method in enumerate(self.methods):
            own, dirty = method.view_requests(view)
            first = len(requests)
            requests += [dataclasses.replace(r, key=(k, r.key)) for r in own]
            must |= {first + i for i in dirty}
            spans.append((first, len(requests)))
        placements, drawn = self.view_budget.place(requests, must)
        reserved = iter(self.view_budget.reserved)
        for method, (first, end) in zip(self.methods, spans, strict=True):
            method.place_by_view(placements[first:end],
                                 {i - first for i in drawn if first <= i < end},
                                 [next(reserved) for _ in method.reserved_sides])

    def _pass_on_what_is_left(self, shares: list[float], create, radius: float,
                              budget_mib: float) -> None:
        """A light that leaves part of its share (a lamp whose statics fit one cube of maps, a
        sun held to the GL's layers) is held to what it takes, and the rest goes to the lights
        short of theirs, by reach, planned anew with it (``create(k, share)``). Each light keeps
        its limit's layers in the array (reserved_layers), so one that clumps anew, moved,
        never moves another's maps."""
        short = [k for k, m in enumerate(self.methods)
                 if isinstance(m, SharesBudget) and m.wants_memory]
        givers = [k for k in range(len(self.methods)) if k not in short]
        spare = sum(shares[k] - self.methods[k].memory_mib for k in givers)
        for k in givers:
            method = self.methods[k]
            if isinstance(method, SharesBudget):
                method.limit_memory(method.memory_mib)
        if not short or spare <= 0:
            return
        weights = {k: reach_weight(self.methods[k].light, radius) for k in short}
        for k in short:
            self.methods[k] = create(k, shares[k] + spare * weights[k] / sum(weights.values()))
        who = (f"light {short[0]} is short of its share" if len(short) == 1 else
               f"lights {', '.join(map(str, short))} are short of their shares")
        self._notes.append(f"{who} of the {budget_mib:g} MiB budget and get"
                           f"{'s' if len(short) == 1 else ''} the {spare:.1f} MiB the others "
                           "leave of theirs")

    def __len__(self) -> int:
        return len(self.methods)

    @property
    def notes(self) -> list[str]:
        """Each light's notes; with several lights, each says which lights it is about, once
        for all the lights that say the same (sixteen street lamps under ``csm``, say)."""
        if len(self.methods) == 1:
            return self._notes + self.methods[0].notes
        said: dict[str, list[int]] = {}
        for k, m in enumerate(self.methods):
            for note in m.notes:
                said.setdefault(note, []).append(k)
        return self._notes + [f"{named_lights(lights)}: {note}" for note, lights in said.items()]

    def prepare(self) -> ArrayShape:
        """What the depth array must hold for the next plan: the shared atlas made anew
        first where characters or clumps came or went."""
        self._check_view_budget()
        return ArrayShape(self._resolution(), self._places()[1])

    @property
    def array_mib(self) -> float:
        """The memory of the depth array the plans need, with its depth bounds."""
        return self._places()[1] * layer_bytes(self._resolution()) / 2**20

    def _resolution(self) -> int:
        """Texels per side of the array's layers: the largest any light's method asks."""
        return max(m.resolution for m in self.methods)

    def _places(self) -> tuple[list[tuple[int, int]], int]:
        """Where each light's first layer goes: (array layer, square in it), and the layers
        they take. A light whose layers are smaller than the array's takes squares of array
        layers, after the previous light's squares of the same size; a layer never holds
        squares of two sizes."""
        if self.view_budget is not None:  # one atlas: the maps' layers are the array's
            return [(0, 0)] * len(self.methods), self.view_budget.atlas.layers
        places, layer, used, size = [], 0, 0, None
        resolution = self._resolution()
        for method in self.methods:
            per = (resolution // method.resolution) ** 2
            if used and (method.resolution != size or used == per):
                layer, used = layer + 1, 0
            places.append((layer, used))
            size = method.resolution
            squares = used + (method.reserved_layers if len(self.methods) > 1 else method.layers)
            layer, used = layer + squares // per, squares % per
        return places, layer + (1 if used else 0)

    def mark_rendered_lost(self) -> None:
        for method in self.methods:
            method.mark_rendered_lost()

    @property
    def counts_pixels(self) -> bool:
        """Whether the shading pass should count the pixels that read each map: some light's
        maps are sized by them."""
        return any(m.counts_pixels for m in self._view_sized())

    def served(self, pixels: list[np.ndarray | None]) -> None:
        """Per map of the last plan counted, light by light, the pixels near its shadow edges
        (None for a light not counted)."""
        for method, own in zip(self.methods, pixels, strict=True):
            if own is not None and isinstance(method, ViewSized):
                method.served(own)

    def _whole_spheres(self, k: int, objects: list[int]) -> np.ndarray:
        """The casters' spheres of light ``k``'s map drawn as the whole statics ``objects``,
        made once per light and set of statics (the plan asks again every frame)."""
        key = (k, tuple(objects))
        if key not in self._whole:
            g = self._geom
            self._whole[key] = np.concatenate([
                caster_spheres(g.static_points[o - g.n_floors],
                               lambda i=o - g.n_floors: g.static_corners(i), self._eyes[k])
                for o in objects])
        return self._whole[key]

    @property
    def placed_blind(self) -> bool:
        """Whether the last plan placed view-sized maps before any pixels were counted (the
        first frame): the renderer then counts them and has them placed anew at once."""
        shared = self.view_budget is not None and self.view_budget.blind
        return shared or any(m.placed_blind for m in self._view_sized())

    def place_anew(self) -> None:
        """Every view-sized map placed (and drawn) anew on the next plan."""
        if self.view_budget is not None:
            self.view_budget.forget()
        for method in self._view_sized():
            method.place_anew()

    def _view_sized(self) -> list[ViewSized]:
        return [m for m in self.methods if isinstance(m, ViewSized)]

    def plan(self, models: np.ndarray, view=None) -> tuple[ShadowPlan, list[LightSpan]]:
        """This frame's maps of every light in one plan, and each light's span of it."""
        self._check_view_budget()
        places = self._places()[0]
        if self._bases is not None and places != self._bases:
            # A light's share of the array moved: what its layers held belongs to another.
            self.mark_rendered_lost()
        self._bases = places
        if self.view_budget is not None:
            self._place_by_view(view)
        plans = [m.plan(models, view) for m in self.methods]
        if len(plans) == 1:
            return plans[0], [LightSpan(0, len(plans[0].maps), 0)]
        resolution = self._resolution()
        combined = ShadowPlan(resolution=resolution, maps=[],
                              static_pieces=plans[0].static_pieces,
                              light_first_maps=[])
        spans = []
        for k, (plan, (base, first_square)) in enumerate(zip(plans, places, strict=True)):
            first = len(combined.maps)
            side = resolution // plan.resolution  # squares per side of an array layer
            for rec in plan.maps:
                square = first_square + rec.layer
                within = square % (side * side)
                origin = (within % side * plan.resolution + rec.origin[0],
                          within // side * plan.resolution + rec.origin[1])
                # The index buffer holds light 0's clump order; other lights' clumps are drawn
                # as whole statics (the map's frustum keeps only what it holds), so their
                # casters' spheres are the whole statics'.
                whole = k > 0 and rec.spheres is not None
                combined.maps.append(dataclasses.replace(
                    rec, layer=base + square // (side * side), origin=origin,
                    pieces=rec.pieces if k == 0 else None,
                    spheres=self._whole_spheres(k, rec.objects) if whole else rec.spheres))
            combined.render_static += [first + i for i in plan.render_static]
            combined.render_dynamic += [first + i for i in plan.render_dynamic]
            if plan.characters is not None:
                combined.characters = plan.characters + (combined.characters
                                                         or CharacterCounts())
            combined.backlog += plan.backlog
            spans.append(LightSpan(first, len(plan.maps), base))
            combined.light_first_maps.append(first)
        if self.view_budget is not None:
            combined.backlog = self.view_budget.backlog
        return combined, spans


def scene_radius(geom: PackedGeometry) -> float:
    """Half the diagonal of the ground plan (x, z) of the floors and statics."""
    fixed = geom.objects < geom.first_character
    if not fixed.any():
        return 1.0
    points = geom.positions[fixed][:, [0, 2]]
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) / 2


def named_lights(lights: list[int]) -> str:
    """``light 3``, or ``lights 1-16`` and ``lights 0, 2, 5-7`` for several, runs joined."""
    if len(lights) == 1:
        return f"light {lights[0]}"
    runs: list[list[int]] = []
    for k in lights:
        if runs and k == runs[-1][-1] + 1:
            runs[-1].append(k)
        else:
            runs.append([k])
    parts = [f"{r[0]}" if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs]
    return f"lights {', '.join(parts)}"
