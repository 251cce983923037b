"""The depth-array layers of one light's fixed clump and character maps.

Layers are handed out from a pool: a clump keeps its layers while it exists, a removed one gives
them back, and a new one takes the lowest free layer, so the array only grows when every layer
is in use. The memory budget and the GL's array limit cap how many the light may take.
"""

from __future__ import annotations

from game.shadows.plan import layer_bytes


class LayerPool:
    """Layers of ``resolution`` texels taken and given back, within the light's limit."""

    def __init__(self, budget_mib: float, resolution: int, max_layers: int):
        self.max_layers = max_layers
        self.budget_layers = int(budget_mib * 2**20 // layer_bytes(resolution))
        self.limit = max(2, min(self.budget_layers, max_layers))
        self.free: list[int] = []  # layers given back, reused lowest first
        self.high = 0              # layers ever handed out

    def take(self) -> int:
        """The lowest free layer, or a new one above every layer handed out."""
        if self.free:
            self.free.sort()
            return self.free.pop(0)
        self.high += 1
        return self.high - 1

    def give(self, layer: int) -> None:
        self.free.append(layer)

    @property
    def fixed(self) -> int:
        """The layers the maps take: every layer ever handed out (at least one)."""
        return max(1, self.high)

    @property
    def spare(self) -> int:
        """Layers that may still be taken: below the limit, or given back."""
        return self.limit - self.fixed + len(self.free)

    def hold_to(self, mib: float, resolution: int) -> None:
        """Take no more layers than ``mib`` holds (nor than the limit already set)."""
        self.budget_layers = int(mib * 2**20 // layer_bytes(resolution))
        self.limit = max(2, min(self.budget_layers, self.max_layers, self.limit))
