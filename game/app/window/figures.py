"""What the overlay reports about one frame (:class:`Figures`), which of its timed passes it
shows, in which order and in which colour (:class:`PassHistory`), and the entry of the window's
stats file that the figures make (:func:`stats_entry`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from imgui_bundle import imgui

from game.app.window import soft_controls
from game.render.frame import Frame
from game.render.passes import DRAWING_PASSES, GBUFFER, READBACK, TOTAL
from game.shadows.plan import CharacterCounts
from game.soft.methods import is_raster

if TYPE_CHECKING:
    from game.soft.tracer import TraceSettings
    from game.soft.upsample import ReducedState

# The window's own work after the scene's passes; shown after "total", which leaves it out.
PRESENT = "present"     # the frame copied or drawn into the window
OVERLAY = "overlay"     # the overlay built and drawn over it
WINDOW_PASSES = (PRESENT, OVERLAY)
# Passes not listed: reading the frame back is a copy for files, not part of drawing it.
HIDDEN_PASSES = (READBACK, GBUFFER)
# The tracer's sub-totals and parts: counted in the passes above and in "total".
HIDDEN_SUFFIXES = ("_total", "_build_static", "_build_dynamic", "_trace_discarded")
HISTORY_FRAMES = 300               # frames in the rolling graph
# One colour per pass, the same in the graph and in the HUD's bar: DRAWING_PASSES, "total" and
# WINDOW_PASSES in turn (Tableau 10 and three more, one for each of them); any other pass
# takes the next one round.
PASS_COLOURS = tuple(imgui.ImVec4(((c >> 16) & 255) / 255, ((c >> 8) & 255) / 255,
                                  (c & 255) / 255, 1.0)
                     for c in (0x4E79A7, 0xF28E2B, 0xE15759, 0x76B7B2, 0x59A14F, 0xEDC948,
                               0xB07AA1, 0xFF9DA7, 0x9C755F, 0xBAB0AC, 0xD37295, 0x8CD17D,
                               0x17BECF))


def shown_pass(name: str) -> bool:
    """Whether the panel lists a pass of the frame's times (sub-totals are left out)."""
    return name not in HIDDEN_PASSES and not name.endswith(HIDDEN_SUFFIXES)


@dataclass
class SoftFigures:
    """The window's soft trace this frame: what the HUD and the panel say about it."""

    size: tuple[int, int]     # pixels traced, columns x rows
    divisor: int              # one traced pixel per divisor x divisor of the frame
    samples: int              # per traced pixel, or the maps of a raster method
    ms: float                 # the trace: its build and its dispatches
    state: str = ""           # accumulation, e.g. "still: 5/16 of round 1 of 2"
    unit: str = "samples"     # what ``samples`` counts: "samples" or "maps"

    @staticmethod
    def of(frame: Frame, state: ReducedState | None, settings: TraceSettings
           ) -> SoftFigures | None:
        """What the overlay says about the frame's soft shadows, made with ``settings``, in
        ``state`` (None: soft shadows off)."""
        if frame.soft is None or state is None:
            return None
        count = soft_controls.count_of(settings)
        if is_raster(settings.method):
            return SoftFigures(size=state.size, divisor=state.divisor, samples=count,
                               ms=frame.ms.get("soft_total", 0.0), unit="maps",
                               state=_raster_state(settings.method, state, count))
        if state.converged:
            note = f"still: converged, {state.rounds} rounds of every pixel; nothing traced"
        elif state.round or state.phase > 1:
            note = (f"still: {state.phase}/{state.phases} of round {state.round + 1} of "
                    f"{state.rounds}" + (", every pixel its own" if state.full else ""))
        else:
            note = "moving: upsampled from this frame's trace"
        return SoftFigures(size=state.size, divisor=state.divisor, samples=count,
                           ms=frame.ms.get("soft_total", 0.0), state=note)


def _raster_state(method: str, state: ReducedState, maps: int) -> str:
    """A raster method's picture is whole at once; segment-maps' still view refines it with
    maps from more points of the segment (``state``'s rounds: sets of ``maps`` points); then a
    still view settles its pixels to the exact visibility (``state.settled`` of them)."""
    exact = f"; exact at {100 * state.settled:.0f}% of pixels" if state.settled else ""
    if state.rounds <= 1:
        return f"{method}: looked up every frame, whole at once" + exact
    if state.round <= 1:
        return f"moving: {maps} points along the segment, looked up this frame"
    held = f"{state.round * maps} of {state.rounds * maps} points along the segment"
    return f"still: {held}" + ("; refined" if state.converged else "") + exact


@dataclass
class Figures:
    """What the overlay reports about one frame."""

    ms: dict[str, float]
    clock: str
    maps_rendered: int
    maps_cached: int
    triangles_to_maps: int
    maps_per_fragment: float | None   # None until a frame has been read back
    fps: float | None
    fps_from_total: bool = False      # headless: 1000 / total ms, not frames over wall time
    texels_to_maps: int = 0
    characters: CharacterCounts | None = None  # the character maps (ShadowPlan.characters)
    soft: SoftFigures | None = None   # the window's soft trace, when soft shadows are on
    maps_waiting: int = 0             # view-sized clump maps whose new side waits
    map_candidates_per_fragment: float | None = None  # records considered, read or not
    depth_first: bool = False         # the camera pass drew its depth before it shaded

    @staticmethod
    def of(frame: Frame, clock: str, fps: float | None,
           maps_per_fragment: float | None = None,
           map_candidates_per_fragment: float | None = None) -> Figures:
        """``frame``'s figures; the per-fragment counts of the last frame read back where
        ``frame`` was not."""
        mpf = frame.maps_per_fragment
        candidates = frame.map_candidates_per_fragment
        return Figures(ms={k: v for k, v in frame.ms.items() if shown_pass(k)},
                       clock=clock, maps_rendered=frame.maps_rendered,
                       maps_cached=frame.maps_cached,
                       triangles_to_maps=frame.triangles_to_maps,
                       maps_per_fragment=mpf if mpf is not None else maps_per_fragment, fps=fps,
                       texels_to_maps=frame.texels_to_maps, characters=frame.characters,
                       maps_waiting=frame.maps_waiting,
                       map_candidates_per_fragment=(candidates if candidates is not None
                                                    else map_candidates_per_fragment),
                       depth_first=frame.depth_first)


class PassHistory:
    """Each pass's milliseconds over the last :data:`HISTORY_FRAMES` frames (NaN where a frame
    did not time it), the order the overlay lists the passes in, and their colours."""

    def __init__(self) -> None:
        self.ms: dict[str, np.ndarray] = {}
        self.frames_seen = 0
        self._colour_index = {name: i for i, name in
                              enumerate((*DRAWING_PASSES, TOTAL, *WINDOW_PASSES))}

    def record(self, ms: dict[str, float]) -> None:
        """One frame's times: each pass's history moves on by one frame."""
        for name, value in ms.items():
            if name not in self.ms:
                self.ms[name] = np.full(HISTORY_FRAMES, np.nan, np.float32)
            self.ms[name][:-1] = self.ms[name][1:]
            self.ms[name][-1] = value
        for name, values in self.ms.items():
            if name not in ms:
                values[:-1] = values[1:]
                values[-1] = np.nan
        self.frames_seen += 1

    def clear(self) -> None:
        self.ms.clear()
        self.frames_seen = 0

    def names(self) -> list[str]:
        """The passes seen, in draw order; any other pass, "total", then the window's."""
        known = [n for n in DRAWING_PASSES if n in self.ms]
        others = sorted(n for n in self.ms
                        if n not in DRAWING_PASSES and n not in WINDOW_PASSES and n != TOTAL)
        window = [n for n in WINDOW_PASSES if n in self.ms]
        return known + others + ([TOTAL] if TOTAL in self.ms else []) + window

    def colour(self, name: str) -> imgui.ImVec4:
        """The colour of a pass, the same in the graph and the HUD's bar."""
        if name not in self._colour_index:
            self._colour_index[name] = len(self._colour_index)
        return PASS_COLOURS[self._colour_index[name] % len(PASS_COLOURS)]


def stats_entry(index: int, time: float, frame: Frame, figures: Figures, method: str,
                soft: bool) -> dict:
    """The stats file's entry of frame ``index``, shown at scene ``time`` with ``method`` and
    soft shadows on or off: each pass's ms (under "ms" and flat), the maps' counts and, with
    soft shadows on, the trace's size (columns, rows) and samples."""
    ms = {name: round(value, 4) for name, value in figures.ms.items()}
    mpf = frame.maps_per_fragment
    trace = figures.soft
    return {"frame": index, "time": time, "ms": ms, **ms,
            "maps_rendered": frame.maps_rendered, "maps_cached": frame.maps_cached,
            "maps_total": frame.maps_total, "triangles_to_maps": frame.triangles_to_maps,
            "maps_per_fragment": None if mpf is None else round(mpf, 5),
            **({} if frame.map_candidates is None else {
                "map_candidates_per_fragment": round(frame.map_candidates_per_fragment, 5)}),
            "depth_first": frame.depth_first, "method": method, "soft": soft,
            **({} if trace is None else {"soft_trace_size": list(trace.size),
                                         "soft_samples": trace.samples})}
