"""Shadow settings fitted inside the GL's limits and the shadow memory budget.

Map resolutions above GL_MAX_TEXTURE_SIZE, more maps than GL_MAX_ARRAY_TEXTURE_LAYERS (or than
the uniform block of map records holds) and depth arrays over the memory budget degrade with a
note, never crash and never drop a shadow. The degradations, in order:

1. a resolution above GL_MAX_TEXTURE_SIZE is clamped to it;
2. a budgeted depth array (clumped) over the budget gets coarser layers: the resolution halves
   until the fewest layers it needs fit; the baselines keep the resolution asked for up to
   their own budget, ``BASELINE_BUDGET_SHARE`` times it, past which every map's side halves
   (or, where nothing fits, they are refused in one line before the driver is asked);
3. the clumped method then shares layers (game/shadows/methods/clumped/): fewer, larger
   clumps; character maps packed into the layers left, the largest halved where they do not
   fit, and merged into shared maps where they outnumber the map records.

Each step adds a one-line note that the command line prints as ``note: ...`` and the stats file
records under ``notes``.
"""

from __future__ import annotations

import dataclasses

from game.errors import GameError
from game.gpu.limits import GLLimits
from game.shadows.plan import ShadowSettings, budget_of, layer_bytes
from game.shadows.registry import method_class

MIN_MAP_RESOLUTION = 64        # texels per side below which a map is useless; never halve past it
# The baselines are comparisons at the resolution they name, so their budget is wider than the
# clumped method's own: 2 GiB at the default, which every shipped scene's baseline fits (night
# town's static-dynamic takes the most, 896 MiB); many lights with no range (a cube of maps
# each) would ask the driver for tens of GiB.
BASELINE_BUDGET_SHARE = 4
BASELINE_RESOLUTIONS = ("single_resolution", "lamp_resolution", "cascade_resolution")


def fit_settings(settings: ShadowSettings, limits: GLLimits,
                 n_characters: int) -> tuple[ShadowSettings, list[str]]:
    """``settings`` with resolutions inside the GL limits and the memory budget, plus notes.

    Returns ``(settings, notes)``; ``settings`` is a new object when anything changed.
    """
    notes: list[str] = []
    changes: dict[str, int] = {}
    method = method_class(settings.method)
    used = method.resolution_fields
    if not used:  # no maps
        return settings, notes
    needed = method.min_layers(settings, n_characters)
    for name in used:
        value = getattr(settings, name)
        if value > limits.max_texture_size:
            changes[name] = limits.max_texture_size
            notes.append(f"{name.replace('_', '-')} {value} is above this GL's "
                         f"GL_MAX_TEXTURE_SIZE; clamped to {limits.max_texture_size}")
    if not method.budgeted:
        # The memory budget is the clumped method's (it sets its number of clumps); a baseline
        # gets the resolution it was asked for, within the GL's limit, so that a comparison at
        # a given resolution is made at that resolution.
        return (dataclasses.replace(settings, **changes) if changes else settings), notes
    budget = budget_of(settings) * 2**20
    name = used[0]
    res = changes.get(name, getattr(settings, name))
    start = res
    while res > MIN_MAP_RESOLUTION and layer_bytes(res) * needed > budget:
        res //= 2
    if res != start:
        changes[name] = res
        notes.append(f"{name.replace('_', '-')} {start} needs {needed} x "
                     f"{layer_bytes(start) / 2**20:g} MiB, over the {budget_of(settings):g} MiB "
                     f"shadow budget; using {res}")
    # The later fields size maps that use a corner of one layer (the characters'): at most the
    # layer's resolution.
    for corner in used[1:]:
        value = changes.get(corner, getattr(settings, corner))
        if value > res:
            changes[corner] = res
            notes.append(f"{corner.replace('_', '-')} {value} is above the array's layers "
                         f"({res} texels); using {res}")
    if not changes:
        return settings, notes
    return dataclasses.replace(settings, **changes), notes


def fit_baseline_memory(settings: ShadowSettings, resolution: int,
                        layers: int) -> tuple[ShadowSettings, str] | None:
    """A baseline's settings with every map's side halved as often as its depth array
    (``layers`` of ``resolution`` texels per side) needs to fit the baselines' budget, and the
    note; None where it fits, or for a method with a budget of its own or no maps.

    Raises GameError (one line) where even maps of MIN_MAP_RESOLUTION do not fit."""
    method = method_class(settings.method)
    if method.budgeted or not method.resolution_fields or not layers:
        return None
    budget_mib = BASELINE_BUDGET_SHARE * budget_of(settings)
    res, halvings = resolution, 0
    while res > MIN_MAP_RESOLUTION and layer_bytes(res) * layers > budget_mib * 2**20:
        res, halvings = res // 2, halvings + 1
    needs = f"{layers} maps of {resolution}^2 need {layer_bytes(resolution) * layers / 2**20:g} MiB"
    if layer_bytes(res) * layers > budget_mib * 2**20:
        raise GameError(f"{settings.method}: {needs}, and even maps of {res}^2 are over the "
                        f"{budget_mib:g} MiB the baselines may take ({BASELINE_BUDGET_SHARE} x "
                        "the shadow budget); use fewer lights, or give them a range")
    if not halvings:
        return None
    smaller = {f: max(1, getattr(settings, f) >> halvings) for f in BASELINE_RESOLUTIONS}
    return dataclasses.replace(settings, **smaller), (
        f"{settings.method}: {needs}, over the {budget_mib:g} MiB the baselines may take "
        f"({BASELINE_BUDGET_SHARE} x the shadow budget); every map's side is halved "
        f"{halvings} time(s), to {res}^2 at most")
