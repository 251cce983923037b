"""Clump maps sized by what the view needs, inside the shadow memory budget.

With a fixed texel density every clump map has the same side, near the camera or 300 m away. Here
each frame gives each clump map a power-of-two side between a minimum and the array's layer side,
from what its owner measures in the view (the clumped method's requests:
game/shadows/methods/clumped/view_maps.py): the map's weight, the length of its shadow edges on
screen times its need, counted in the shading pass of earlier frames (shaders/shadow.glsl). A map
misclassifies pixels in proportion to its weight over its side; for a fixed sum of squares their
total is least when each side goes as the cube root of the weight. Before a map is counted its
edges are taken as long as it is wide on screen, which makes the side go as the need to the power
2/3. All are scaled by one factor, the largest for which the sides fit the budget. Sides grow at
once and shrink only when the need falls well under the smaller side (the characters' hysteresis,
game/shadows/crowd.py), the sides it holds paid for by the scale, so small camera moves re-render
nothing.
The maps live in squares of the array's layers (game/shadows/atlas.py); a map keeps its square
while its side stays, and a cached map is drawn again only when its side changes, its clump
does, or it is moved aside to make room for a larger square. At most ``max_renders`` maps are
drawn again in a frame; the others keep their old side and square, and
:attr:`ViewBudget.backlog` counts them. The maps of several lights may share one budget
(game/shadows/lights.py). Holds no GL object.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass

import numpy as np

from game.shadows.atlas import Atlas, Square
from game.shadows.crowd import CrowdPlanner, held_sizes, pow2_at_least
from game.shadows.fit import MapFit

# The most the needs are scaled up to fill the budget (a need of 128 texels may become 4096).
MAX_SCALE = 32.0


def atlas_shape(texels: int, min_side: int, max_side: int) -> tuple[int, int]:
    """Layers and side of an atlas that holds ``texels``: the largest power-of-two side from
    ``min_side`` up to ``max_side`` whose whole layers hold them with at most a quarter more."""
    side = pow2_at_least(max(max_side, min_side))
    while side > min_side and max(1, -(-texels // side ** 2)) * side ** 2 > 1.25 * texels:
        side //= 2
    return max(1, -(-texels // side ** 2)), side


@dataclass
class Placement:
    """Where a clump's maps are this frame: their side, their squares and their fits."""

    side: int
    squares: list[Square]
    fits: list[MapFit]


@dataclass(frozen=True)
class ClumpRequest:
    """A clump's maps (the clumped method asks for each map apart) as the budget sees them: a
    key that stays while the clump is unchanged, how many maps, the side the view asks, their
    fits at a given side, and their weight: the length in pixels of their shadow edges times
    the need and the texels per pixel, to which the pixels they misclassify at a given side
    are proportional (None: edges as long as the maps are wide in pixels, the need
    squared)."""

    key: Hashable
    maps: int
    need: float
    refit: Callable[[int], list[MapFit]]
    weight: float | None = None


class ViewBudget:
    """Sides and squares of the clump maps, frame after frame."""

    def __init__(self, layers: int, resolution: int, min_side: int, reserved: list[int],
                 max_renders: int):
        self.atlas = Atlas(layers, resolution)
        self.min_side = min(min_side, resolution)
        self.max_renders = max_renders
        self._reserved_sides = list(reserved)
        self.reserved = [self.atlas.take(side) for side in reserved]
        if any(square is None for square in self.reserved):
            raise ValueError("the character maps' squares do not fit the shadow budget")
        self._sizes = CrowdPlanner(self.min_side, resolution)
        self.placed: dict[Hashable, Placement] = {}
        self.backlog = 0
        self.blind = False

    @property
    def capacity(self) -> int:
        """Texels the clump maps may take."""
        total = self.atlas.layers * self.atlas.resolution ** 2
        return total - sum(s * s for s in self._reserved_sides)

    def sides(self, requests: list[ClumpRequest]) -> list[int]:
        """Each clump's side this frame: from its weight (or need), all scaled by one factor,
        the largest for which the sides, with the hysteresis, fit the budget (below 1 where
        the needs exceed it, so near maps keep more texels than far ones; above 1 where they
        leave texels unused, since finer maps only make shadows more exact)."""
        counts = np.array([r.maps for r in requests], np.int64)
        needs = np.array([r.need for r in requests], float)
        weights = np.array([r.need ** 2 if r.weight is None else r.weight
                            for r in requests], float)
        if len(needs) and needs.max() > 0 and weights.max() > 0:
            needs = np.cbrt(weights) * (needs.max() / np.cbrt(weights.max()))

        keys = [r.key for r in requests]
        last = self._sizes.last_sizes(keys)

        def texels(scale: float) -> int:
            # With the hysteresis, as the sides will be given: the sides it holds are paid for
            # by a smaller scale, not by cutting maps that need theirs.
            sides = held_sizes(needs * scale, last, self.min_side, self.atlas.resolution)
            return int(counts @ (sides * sides))

        if texels(0.0) > self.capacity:
            raise ValueError("the clump maps do not fit the shadow budget at their smallest "
                             "side")
        low, high = 0.0, MAX_SCALE
        for _ in range(32):  # the largest scale that fits
            scale = (low + high) / 2
            low, high = (scale, high) if texels(scale) <= self.capacity else (low, scale)
        # The keys themselves name the maps: spelling out a clump's members each frame cost
        # more than the rest of the search.
        return self._sizes.sizes(keys, needs * low)

    def place(self, requests: list[ClumpRequest], must: set[int]) -> tuple[list[Placement],
                                                                          set[int]]:
        """Placements for every clump (in order) and the clumps whose maps are drawn this
        frame: those in ``must`` (their content changed), new ones, and up to
        :attr:`max_renders` maps whose side changed, smaller first (they free squares). A map
        whose larger side finds no free square gets one made by moving smaller maps aside
        (drawn again, within the cap), or keeps its old side and waits; only a new clump that
        finds none has every square laid out anew."""
        # Placed blind: every map anew, with no weight measured (the first frame).
        self.blind = (bool(requests) and not self.placed
                      and all(r.weight is None for r in requests))
        sides = self.sides(requests)
        keys = {r.key for r in requests}
        gone = [k for k in self.placed if k not in keys]
        for key in gone:
            for square in self.placed.pop(key).squares:
                self.atlas.give(square)
        if gone:
            self._sizes.forget(keys)
        changes = [i for i, r in enumerate(requests)
                   if r.key not in self.placed or self.placed[r.key].side != sides[i]]
        forced = [i for i in changes if requests[i].key not in self.placed]
        index = {r.key: i for i, r in enumerate(requests)}
        optional = sorted((i for i in changes if i not in forced),
                          key=lambda i: (sides[i] > self.placed[requests[i].key].side,
                                         -requests[i].need))
        budget = self.max_renders - sum(requests[i].maps for i in forced)
        drawn = set(must) | set(forced)
        self.backlog = 0
        for i in optional:
            request = requests[i]
            if i not in must and i not in drawn and budget < request.maps:
                self.backlog += 1
                continue
            old = self.placed[request.key]
            side = sides[i]
            squares = self._retake(old.squares, side, request.maps)
            if squares is None and side > old.side:  # room made by moving small maps aside
                done = {requests[j].key for j in drawn}  # drawn anyway: free to move
                own = 0 if i in must or i in drawn else request.maps
                squares, moved = self._make_room(request.key, side, request.maps,
                                                 budget - own, done)
                for key in moved:
                    if index[key] not in drawn:
                        drawn.add(index[key])
                        budget -= len(self.placed[key].squares)
            if squares is None:  # no room as the squares lie: the old side and squares
                self.backlog += 1
                for square in old.squares:
                    self.atlas.take_again(square)
                if i not in must:
                    continue
                side, squares = old.side, old.squares
            budget -= 0 if i in must or i in drawn else request.maps
            drawn.add(i)
            self.placed[request.key] = Placement(side, squares, request.refit(side))
        for i in set(must) - set(changes):  # same side, new content (the light moved)
            self.placed[requests[i].key].fits = requests[i].refit(sides[i])
        for i in sorted(forced, key=lambda i: -sides[i]):
            squares = self._retake([], sides[i], requests[i].maps)
            if squares is None:
                return self._repack(requests, sides), set(range(len(requests)))
            self.placed[requests[i].key] = Placement(sides[i], squares,
                                                     requests[i].refit(sides[i]))
        placed = [self.placed[r.key] for r in requests]
        # The hysteresis goes from the sides the maps have, not those they asked: a map that
        # waits has not the texels it asked for.
        self._sizes.settle([r.key for r in requests], [p.side for p in placed])
        return placed, drawn

    def _make_room(self, own: Hashable, side: int, count: int, budget: int,
                   done: set[Hashable]) -> tuple[list[Square] | None, list[Hashable]]:
        """``count`` squares of ``side`` for map ``own`` (its old squares given back) where the
        free texels are too broken up for one: each the aligned square whose smaller maps are
        fewest, those moved to free squares elsewhere, at most ``budget`` maps drawn again
        (those in ``done`` are drawn this frame anyway). Returns the squares (None, nothing
        moved, when no such square is found) and the keys of the maps moved."""
        atlas = self.atlas.copy()
        placed = {k: list(p.squares) for k, p in self.placed.items() if k != own}
        squares, moved = [], set()
        for _ in range(count):
            found = free_a_square(atlas, placed, self.reserved, side, budget, done | moved)
            if found is None:
                return None, []
            square, keys = found
            squares.append(square)
            budget -= sum(len(placed[k]) for k in keys - moved - done)
            moved |= keys
        self.atlas.restore(atlas)
        for key in moved:
            self.placed[key].squares = placed[key]
        return squares, sorted(moved, key=str)

    def _retake(self, old: list[Square], side: int, count: int) -> list[Square] | None:
        """Give back ``old`` and take ``count`` squares of ``side``; None, with nothing taken
        (``old`` given back all the same), when they do not fit."""
        for square in old:
            self.atlas.give(square)
        squares = [self.atlas.take(side) for _ in range(count)]
        if any(s is None for s in squares):
            for s in squares:
                if s is not None:
                    self.atlas.give(s)
            return None
        return squares

    def _repack(self, requests: list[ClumpRequest], sides: list[int]) -> list[Placement]:
        """Every square anew (the free space was too broken up): every map is drawn again."""
        wanted = self._reserved_sides + [s for r, s in zip(requests, sides, strict=True)
                                         for _ in range(r.maps)]
        squares = self.atlas.repack(wanted)
        if squares is None:
            raise ValueError("the clump maps do not fit the shadow budget")
        self.reserved = squares[:len(self._reserved_sides)]
        rest = iter(squares[len(self._reserved_sides):])
        self.placed = {}
        for r, side in zip(requests, sides, strict=True):
            self.placed[r.key] = Placement(side, [next(rest) for _ in range(r.maps)],
                                           r.refit(side))
        self.backlog = 0
        return [self.placed[r.key] for r in requests]

    @property
    def held(self) -> set[Hashable]:
        """The keys whose side the hysteresis holds."""
        return self._sizes.held

    def forget(self) -> None:
        """Every clump is placed anew on the next frame (its squares are given back), its side
        from its weight alone (no hysteresis)."""
        for placement in self.placed.values():
            for square in placement.squares:
                self.atlas.give(square)
        self.placed = {}
        self._sizes.forget(set())


def free_a_square(atlas: Atlas, placed: dict[Hashable, list[Square]], fixed: list[Square],
                   side: int, budget: int, free: set[Hashable]
                   ) -> tuple[Square, set[Hashable]] | None:
    """Free an aligned square of ``side`` in ``atlas`` by moving the smaller squares in it
    (``placed``: each map's squares; ``fixed`` never move) to free squares outside it, their
    maps, but those in ``free``, at most ``budget`` squares; the square taken and the maps
    moved, both ``atlas`` and ``placed`` changed, or None with both as they were. Tries the
    squares whose maps cost fewest draws, then the fewest texels."""
    blocked, inside = set(), {}
    for key, squares in [*placed.items(), (None, fixed)]:
        for sq in squares:
            block = (sq.layer, sq.x - sq.x % side, sq.y - sq.y % side)
            if key is None or sq.side >= side:
                for y in range(sq.y, sq.y + max(sq.side, side), side):
                    for x in range(sq.x, sq.x + max(sq.side, side), side):
                        blocked.add((sq.layer, x - x % side, y - y % side))
            else:
                inside.setdefault(block, []).append((key, sq))
    costs = sorted((sum(len(placed[k]) for k in {k for k, _ in held} - free),
                    sum(sq.side ** 2 for _, sq in held), block)
                   for block, held in inside.items() if block not in blocked)
    for maps, _, block in costs[:8]:
        if maps > budget:
            break
        trial = atlas.copy()
        held = inside[block]
        for _, sq in held:
            trial.give(sq)
        square = Square(*block, side)
        trial.take_again(square)
        moves = [(key, sq, trial.take(sq.side)) for key, sq in held]
        if any(new is None for _, _, new in moves):
            continue
        atlas.restore(trial)
        for key, sq, new in moves:
            placed[key][placed[key].index(sq)] = new
        return square, {key for key, _, _ in moves}
    return None
