"""What this GL allows the shadow maps: texture size, array layers, map records.

game/shadows/budget.py fits the shadow settings inside these limits. Tests simulate a weaker GL
with :meth:`GLLimits.tightened`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from game.gpu import blocks


@dataclass(frozen=True)
class GLLimits:
    """The limits that bound the shadow maps."""

    max_texture_size: int      # GL_MAX_TEXTURE_SIZE: texels per side of one layer
    max_array_layers: int      # GL_MAX_ARRAY_TEXTURE_LAYERS
    max_maps: int              # map records that fit the uniform block (blocks.max_maps)

    @classmethod
    def of(cls, ctx) -> GLLimits:
        """The limits the context reports."""
        return cls(max_texture_size=int(ctx.info["GL_MAX_TEXTURE_SIZE"]),
                   max_array_layers=int(ctx.info["GL_MAX_ARRAY_TEXTURE_LAYERS"]),
                   max_maps=blocks.max_maps(ctx))

    def tightened(self, **smaller: int) -> GLLimits:
        """These limits with some made smaller (never larger): to simulate a weaker GL."""
        return dataclasses.replace(
            self, **{k: min(int(v), getattr(self, k)) for k, v in smaller.items()})

    @property
    def max_layers(self) -> int:
        """Maps one array can hold and the shading pass can index."""
        return min(self.max_array_layers, self.max_maps)
