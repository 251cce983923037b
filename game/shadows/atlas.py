"""Squares of the depth array's layers, handed out and taken back: a buddy allocator.

Every square has a power-of-two side and sits at a multiple of its side in its layer, so a
square's four quarters are the squares of the next size down. A free square of the size asked
is taken when there is one; otherwise the smallest larger one is split, its other quarters left
free. A square given back joins its three buddies into their parent when all four are free.
Maps keep their square while their size stays, so a cached map moves only when the budget moves
it aside (game/shadows/view_budget.py); :meth:`repack` lays out every square anew (largest
first, which always fits when the total fits) for when the free space is too broken up. Holds
no GL object.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Square:
    """A square of one layer: its layer, its lower corner in texels, its side."""

    layer: int
    x: int
    y: int
    side: int


class Atlas:
    """The squares of ``layers`` layers of ``resolution`` texels (a power of two) per side."""

    def __init__(self, layers: int, resolution: int):
        if resolution & (resolution - 1):
            raise ValueError(f"an atlas layer's side must be a power of two, got {resolution}")
        self.layers = layers
        self.resolution = resolution
        self._free: set[Square] = {Square(k, 0, 0, resolution) for k in range(layers)}

    def copy(self) -> Atlas:
        """An atlas with the same squares free, to try a change on."""
        other = Atlas(self.layers, self.resolution)
        other._free = set(self._free)
        return other

    def restore(self, other: Atlas) -> None:
        """Take the free squares of ``other`` (a changed :meth:`copy`)."""
        self._free = set(other._free)

    @property
    def free_texels(self) -> int:
        return sum(s.side * s.side for s in self._free)

    def take(self, side: int) -> Square | None:
        """A free square of ``side`` texels, or None when none is left."""
        fits = [s for s in self._free if s.side >= side]
        if not fits:
            return None
        square = min(fits, key=lambda s: (s.side, s.layer, s.y, s.x))
        self._free.remove(square)
        while square.side > side:
            half = square.side // 2
            quarters = [Square(square.layer, square.x + dx, square.y + dy, half)
                        for dy in (0, half) for dx in (0, half)]
            self._free.update(quarters[1:])
            square = quarters[0]
        return square

    def take_again(self, square: Square) -> None:
        """Take ``square`` itself, free again (given back, perhaps joined into a larger free
        square since), so that a map given its squares back keeps its place."""
        holder = next(s for s in self._free
                      if s.layer == square.layer and s.side >= square.side
                      and s.x <= square.x < s.x + s.side and s.y <= square.y < s.y + s.side)
        self._free.remove(holder)
        while holder.side > square.side:
            half = holder.side // 2
            quarters = [Square(holder.layer, holder.x + dx, holder.y + dy, half)
                        for dy in (0, half) for dx in (0, half)]
            holder = next(q for q in quarters if q.x <= square.x < q.x + half
                          and q.y <= square.y < q.y + half)
            self._free.update(q for q in quarters if q != holder)

    def give(self, square: Square) -> None:
        """Take back a square handed out by :meth:`take`."""
        while square.side < self.resolution:
            parent = square.side * 2
            px, py = square.x - square.x % parent, square.y - square.y % parent
            buddies = {Square(square.layer, px + dx, py + dy, square.side)
                       for dy in (0, square.side) for dx in (0, square.side)} - {square}
            if not buddies <= self._free:
                break
            self._free -= buddies
            square = Square(square.layer, px, py, parent)
        self._free.add(square)

    def repack(self, sides: list[int]) -> list[Square] | None:
        """Every square anew, for maps of these sides (in their order); None when their texels
        exceed the layers'. Squares taken before are all given back first."""
        self._free = {Square(k, 0, 0, self.resolution) for k in range(self.layers)}
        out: list[Square | None] = [None] * len(sides)
        for i in sorted(range(len(sides)), key=lambda i: -sides[i]):
            out[i] = self.take(sides[i])
            if out[i] is None:
                return None
        return out  # type: ignore[return-value]
