"""Clump maps sized by what the view needs, inside the shadow memory budget.

With a fixed texel density every clump map has the same side, near the camera or 300 m away. Here
each frame gives each clump map a side from the need its owner computes from the view (the
clumped method: game/shadows/methods/clumped.py ``view_requests``), as a power of two between a
minimum and the array's layer side. The sides follow the needs to the power 2/3 (a map's
misclassified pixels go as its edge pixels, about its need, times the edges' offset, the need
over the side: for a fixed sum of squares their total is least so), all scaled by one factor,
the largest for which the sides fit the budget. Sides grow at once and shrink only when the need
falls well under the smaller side (the characters' hysteresis, game/shadows/crowd.py), so small
camera moves re-render nothing.
The maps live in squares of the array's layers (game/shadows/atlas.py); a map keeps its square
while its side stays, and a cached map is drawn again only when its side changes (or its clump
does). At most ``max_renders`` maps change side in a frame, and a larger side waits for a free
square; the others keep their old side and square, and :attr:`ViewBudget.backlog` counts them.
The maps of several lights may share one budget (game/shadows/lights.py). Holds no GL object.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass

import numpy as np

from game.shadows.atlas import Atlas, Square
from game.shadows.crowd import CrowdPlanner, pow2_at_least
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


def pow2_sides(x: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """:func:`~game.shadows.crowd.pow2_at_least` of every element of ``x``, at once: the
    budget's search asks it of every clump some thirty times a frame."""
    x = np.where(np.isfinite(x), np.maximum(x, 1.0), hi)
    return np.clip(2 ** np.ceil(np.log2(x)), lo, hi).astype(np.int64)


@dataclass
class Placement:
    """Where a clump's maps are this frame: their side, their squares and their fits."""

    side: int
    squares: list[Square]
    fits: list[MapFit]


@dataclass(frozen=True)
class ClumpRequest:
    """A clump's maps (the clumped method asks for each map apart) as the budget sees them: a
    key that stays while the clump is unchanged, how many maps, the side the view asks, and
    their fits at a given side."""

    key: Hashable
    maps: int
    need: float
    refit: Callable[[int], list[MapFit]]


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

    @property
    def capacity(self) -> int:
        """Texels the clump maps may take."""
        total = self.atlas.layers * self.atlas.resolution ** 2
        return total - sum(s * s for s in self._reserved_sides)

    def sides(self, requests: list[ClumpRequest]) -> list[int]:
        """Each clump's side this frame: its need, all needs scaled by one factor, the largest
        that fits the budget (below 1 where the needs exceed it, so near maps keep more texels
        than far ones; above 1 where they leave texels unused, since finer maps only make
        shadows more exact), with the hysteresis; then, should the hysteresis's larger sides
        not fit, the largest halved."""
        maps = [r.maps for r in requests]
        counts = np.array(maps, np.int64)
        needs = np.array([r.need for r in requests], float)
        if len(needs) and needs.max() > 0:
            needs = needs ** (2 / 3) * needs.max() ** (1 / 3)

        def texels(scale: float) -> int:
            sides = pow2_sides(needs * scale, self.min_side, self.atlas.resolution)
            return int(counts @ (sides * sides))

        low, high = 0.0, MAX_SCALE
        for _ in range(32):  # the largest scale that fits
            scale = (low + high) / 2
            low, high = (scale, high) if texels(scale) <= self.capacity else (low, scale)
        scale = low
        # The keys themselves name the maps: spelling out a clump's members each frame cost
        # more than the rest of the search.
        sides = self._sizes.sizes([r.key for r in requests], needs * scale)
        while sum(m * s * s for m, s in zip(maps, sides, strict=True)) > self.capacity:
            largest = max(range(len(sides)), key=lambda i: (sides[i], -requests[i].need))
            if sides[largest] <= self.min_side:
                raise ValueError("the clump maps do not fit the shadow budget at their "
                                 "smallest side")
            sides[largest] //= 2
        return sides

    def place(self, requests: list[ClumpRequest], must: set[int]) -> tuple[list[Placement],
                                                                          set[int]]:
        """Placements for every clump (in order) and the clumps whose maps are drawn this
        frame: those in ``must`` (their content changed), new ones, and up to
        :attr:`max_renders` maps whose side changed, smaller first (they free squares). A map
        whose new side finds no free square keeps its old side and waits; only a new clump
        that finds none has every square laid out anew."""
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
        optional = sorted((i for i in changes if i not in forced),
                          key=lambda i: (sides[i] > self.placed[requests[i].key].side,
                                         -requests[i].need))
        budget = self.max_renders - sum(requests[i].maps for i in forced)
        drawn = set(must) | set(forced)
        self.backlog = 0
        for i in optional:
            request = requests[i]
            if i not in must and budget < request.maps:
                self.backlog += 1
                continue
            old = self.placed[request.key]
            side = sides[i]
            squares = self._retake(old.squares, side, request.maps)
            if squares is None:  # no room as the squares lie: the old side and squares
                self.backlog += 1
                for square in old.squares:
                    self.atlas.take_again(square)
                if i not in must:
                    continue
                side, squares = old.side, old.squares
            budget -= 0 if i in must else request.maps
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
        return [self.placed[r.key] for r in requests], drawn

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

    def forget(self) -> None:
        """Every clump is placed anew on the next frame (its squares are given back)."""
        for placement in self.placed.values():
            for square in placement.squares:
                self.atlas.give(square)
        self.placed = {}
