"""What this GL and the memory budget allow, and shadow settings fitted inside it.

Issue 6: map resolutions above GL_MAX_TEXTURE_SIZE, more maps than GL_MAX_ARRAY_TEXTURE_LAYERS (or
than the uniform block of map records holds) and depth arrays over the memory budget must degrade
with a warning, never crash and never drop a shadow. The degradations, in order:

1. a resolution above GL_MAX_TEXTURE_SIZE is clamped to it;
2. a clumped depth array over the budget gets coarser layers (the resolution halves until the
   fewest layers it needs fit); the baselines keep the resolution asked for;
3. the clumped method then shares layers (game/shadow_methods.py): fewer, larger clumps, and when
   even the characters outnumber the free layers, several characters share one map.

Each step adds a one-line note that the command line prints as ``note: ...`` and the stats file
records under ``notes``. Tests simulate small limits with :meth:`GLLimits.tightened`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from game.gpu import blocks as gpu_blocks

DEPTH_TEXEL_BYTES = 4          # GL_DEPTH_COMPONENT32F
MIN_MAP_RESOLUTION = 64        # texels per side below which a map is useless; never halve past it


@dataclass(frozen=True)
class GLLimits:
    """The limits that bound the shadow maps."""

    max_texture_size: int      # GL_MAX_TEXTURE_SIZE: texels per side of one layer
    max_array_layers: int      # GL_MAX_ARRAY_TEXTURE_LAYERS
    max_maps: int              # map records that fit the uniform block (gpu_blocks.max_maps)

    @classmethod
    def of(cls, ctx) -> GLLimits:
        """The limits the context reports."""
        return cls(max_texture_size=int(ctx.info["GL_MAX_TEXTURE_SIZE"]),
                   max_array_layers=int(ctx.info["GL_MAX_ARRAY_TEXTURE_LAYERS"]),
                   max_maps=gpu_blocks.max_maps(ctx))

    def tightened(self, **smaller: int) -> GLLimits:
        """These limits with some made smaller (never larger): to simulate a weaker GL."""
        return dataclasses.replace(
            self, **{k: min(int(v), getattr(self, k)) for k, v in smaller.items()})

    @property
    def max_layers(self) -> int:
        """Maps one array can hold and the shading pass can index."""
        return min(self.max_array_layers, self.max_maps)


def layer_bytes(resolution: int) -> int:
    return DEPTH_TEXEL_BYTES * resolution * resolution


def fit_settings(settings, limits: GLLimits, n_characters: int):
    """``settings`` with resolutions inside the GL limits and the memory budget, plus notes.

    Returns ``(settings, notes)``; ``settings`` is a new object when anything changed.
    """
    notes: list[str] = []
    changes: dict[str, int] = {}
    # The resolution each method's array uses, and the fewest layers clumped can work with.
    if settings.method in ("single", "static-dynamic"):
        used = ("single_resolution",)
        needed = 1 if settings.method == "single" else 2
    elif settings.method == "csm":
        used, needed = ("cascade_resolution",), settings.cascades
    elif settings.method == "clumped":
        # One clump and one (shared) character map.
        used, needed = ("clump_resolution", "character_resolution"), 1 + min(n_characters, 1)
    else:  # traced: no maps
        return settings, notes
    for name in used:
        value = getattr(settings, name)
        if value > limits.max_texture_size:
            changes[name] = limits.max_texture_size
            notes.append(f"{name.replace('_', '-')} {value} is above this GL's "
                         f"GL_MAX_TEXTURE_SIZE; clamped to {limits.max_texture_size}")
    if settings.method != "clumped":
        # The memory budget is the clumped method's (it sets its number of clumps); a baseline
        # gets the resolution it was asked for, within the GL's limit, so that a comparison at
        # a given resolution is made at that resolution.
        return (dataclasses.replace(settings, **changes) if changes else settings), notes
    budget = settings.budget_mib * 2**20
    name = used[0]
    res = changes.get(name, getattr(settings, name))
    start = res
    while res > MIN_MAP_RESOLUTION and layer_bytes(res) * needed > budget:
        res //= 2
    if res != start:
        changes[name] = res
        notes.append(f"{name.replace('_', '-')} {start} needs {needed} x "
                     f"{layer_bytes(start) / 2**20:g} MiB, over the {settings.budget_mib:g} MiB "
                     f"shadow budget; using {res}")
    # A character's map is a corner of one layer of the array.
    character = changes.get("character_resolution", settings.character_resolution)
    if character > res:
        changes["character_resolution"] = res
        notes.append(f"character-resolution {character} is above the array's layers "
                     f"({res} texels); using {res}")
    if not changes:
        return settings, notes
    return dataclasses.replace(settings, **changes), notes
