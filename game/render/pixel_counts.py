"""The view-sized maps' feedback: the pixels near each map's shadow edges, counted by the
shading pass and handed back to the planners.

One frame in ``COUNT_EVERY`` counts; the next frame's plan reads the counts back (long after the
GPU is done with them) and the planners size the maps by them (game/shadows/view_budget.py).
The first frame has no counts to go by: it is planned, drawn and counted, then planned and
drawn again by its own counts.
"""

from __future__ import annotations

from game.render.frame_blocks import FrameBlocks
from game.shadows.lights import LightShadows, LightSpan
from game.shadows.plan import ShadowPlan

# One frame in this many counts the pixels near each map's shadow edges. Counting costs the
# shading pass about a fifth more on llvmpipe (a texture gather per map read and the atomic
# counters); the weights move slowly (game/shadows/methods/clumped/view_maps.py ``served``).
COUNT_EVERY = 4


class PixelCounts:
    """When to count, and the counted plan whose counts the next plan reads back."""

    def __init__(self):
        self.counted: ShadowPlan | None = None  # the last plan, when its draw counted
        self.uncounted = 0                       # frames drawn since the last counted one

    def forget(self) -> None:
        """The planners were made anew: the counts belong to maps that are gone."""
        self.counted = None

    def hand_back(self, shadows: LightShadows, blocks: FrameBlocks, spans: list[LightSpan],
                  lights_on: list[bool]) -> None:
        """Give the planners the last counted frame's pixels, light by light (a light switched
        off read no map: its maps keep what they had)."""
        if self.counted is None:
            return
        pixels = blocks.counted_pixels(len(self.counted.maps))
        shadows.served([pixels[span.first_map:span.first_map + span.map_count] if on else None
                        for span, on in zip(spans, lights_on, strict=True)])
        self.counted = None

    def count_now(self, shadows: LightShadows) -> bool:
        """Whether this frame's shading pass counts: one frame in ``COUNT_EVERY``, and a frame
        placed before any count."""
        count = shadows.counts_pixels and (shadows.placed_blind
                                           or self.uncounted >= COUNT_EVERY - 1)
        self.uncounted = 0 if count else self.uncounted + 1
        return count

    def drawn(self, plan: ShadowPlan, counted: bool) -> None:
        self.counted = plan if counted else None

    def place_again(self, shadows: LightShadows) -> bool:
        """Whether the frame just drawn placed view-sized maps before any pixel was counted
        (the first frame): they are then placed anew at once, by this draw's counts, and the
        frame drawn again."""
        if self.counted is None or not shadows.placed_blind:
            return False
        shadows.place_anew()
        self.uncounted = COUNT_EVERY  # counted at the sides it is placed at
        return True
