"""The window's soft shadows: which soft method traces the linear light, how finely, and the
panel's controls for them.

The default method is chosen by measurement (docs/design/raster-soft.md, "The window's
method"): the lowest error against the analytic visibility, among the recorded soft sweep's
rows on the built-in square, at a cost the window can afford beside its hard frame. The panel
switches among every soft method of the registry (game/soft/methods.py).
"""

from __future__ import annotations

import dataclasses

from game.soft.methods import METHODS, TRACED_METHODS, TraceSettings
from game.soft.upsample import Upsampling

# The window's soft trace: SOFT_METHOD with SOFT_COUNT samples per point (a sampled traced
# method) or maps along the segment (segment-maps), at one pixel per SOFT_DIVISOR x
# SOFT_DIVISOR of the frame. A raster method fills in the rest in the composite
# (game/soft/direct.py); a traced one is upsampled, and while the view stays, SOFT_ROUNDS rounds
# of every pixel accumulate into each pixel's own mean (game/soft/accumulate.py).
SOFT_METHOD = "segment-maps"
SOFT_COUNT = 8
SOFT_DIVISOR = 4
SOFT_ROUNDS = 4
# The panel's control of the count: samples per point or maps, by the method.
COUNT_RANGE = {"samples": (1, 32), "maps": (1, 32)}


def count_name(method: str) -> str | None:
    """What the panel's count slider sets for ``method``: ``samples`` (a sampled traced
    method), ``maps`` (segment-maps), or None (exact, or pcss's one map)."""
    if method == "segment-maps":
        return "maps"
    traced = TRACED_METHODS.get(method)
    return "samples" if traced is not None and traced.sampled else None


def count_of(settings: TraceSettings) -> int:
    """The count the panel and the overlay show for ``settings`` (1 where there is none)."""
    name = count_name(settings.method)
    return getattr(settings, name) if name is not None else 1


def with_count(settings: TraceSettings, count: int) -> TraceSettings:
    """``settings`` with the method's count (samples or maps) set to ``count``."""
    name = count_name(settings.method)
    return dataclasses.replace(settings, **{name: count}) if name is not None else settings


def window_settings() -> TraceSettings:
    """The window's soft trace at its defaults."""
    return with_count(TraceSettings(method=SOFT_METHOD), SOFT_COUNT)


def window_upsampling() -> Upsampling:
    return Upsampling(divisor=SOFT_DIVISOR, rounds=SOFT_ROUNDS)


def choose(settings: TraceSettings, method: str | None, count: int | None) -> TraceSettings:
    """``settings`` with another ``method`` (keeping its count where the new method has one)
    and ``count`` (None: as they are)."""
    if method is not None and method != settings.method:
        if method not in METHODS:
            raise ValueError(f"unknown soft method {method!r}; valid: {', '.join(METHODS)}")
        settings = with_count(dataclasses.replace(settings, method=method), count_of(settings))
    if count is not None:
        settings = with_count(settings, count)
    return settings
