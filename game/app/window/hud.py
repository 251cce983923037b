"""The overlay's HUD, the window's default: a small corner box that covers at most
:data:`HUD_MAX_SHARE` of the window.

It holds the frame rate, the frame's milliseconds and a thin bar of the passes, each a segment as
long as its share of the frame; then a line with the method, the number of lights (where there
are several), with soft shadows on at what resolution they were traced and in how many
milliseconds, and in a window the F1 hint. That line is left out, and then the font shrunk, where
the box would cover more than its share.

Where a light's shadows collapsed (game/shadows/collapse.py), a strip along the bottom of the
window says so, with the HUD and beside the panel alike, whichever tab is open.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from imgui_bundle import imgui

from game.app.window.figures import WINDOW_PASSES, Figures, PassHistory
from game.app.window.imgui_layout import PANEL_MARGIN, font_ratio, window_rect
from game.render.passes import TOTAL

if TYPE_CHECKING:
    from game.render.renderer import Renderer

HUD_MAX_SHARE = 1 / 12
HUD_ALPHA = 0.55
HUD_PADDING = (5.0, 4.0)           # pixels inside the box, x and y
HUD_SPACING = 3.0                  # pixels between its lines
HUD_BAR_HEIGHT = 6.0               # pixels at font scale 1
HUD_FONT_STEPS = (1.0, 0.8, 0.65)  # font sizes tried, relative to the overlay's
# The figures line is at least this wide (a monospace font), so that the box keeps its size as
# the figures change.
HUD_FPS_TEMPLATE = "FPS 0000.0  frame 000.0 ms"
BAR_BACKGROUND = imgui.ImVec4(0.0, 0.0, 0.0, 0.6)
WARNING_COLOUR = imgui.ImVec4(1.0, 0.72, 0.3, 1.0)
MAX_WARNINGS = 2  # collapse notes shown in the strip; the rest are counted
HUD_FLAGS = (imgui.WindowFlags_.no_title_bar.value | imgui.WindowFlags_.no_resize.value
             | imgui.WindowFlags_.no_move.value | imgui.WindowFlags_.no_scrollbar.value
             | imgui.WindowFlags_.no_saved_settings.value | imgui.WindowFlags_.no_inputs.value
             | imgui.WindowFlags_.no_focus_on_appearing.value)


def hud_lights(lights_on: list[bool]) -> str:
    """The HUD's word on the lights: how many, and how many are off; nothing for one light."""
    if len(lights_on) < 2:
        return ""
    off = lights_on.count(False)
    return f"{len(lights_on)} lights" + (f", {off} off" if off else "")


def warning_lines(notes: list[str]) -> tuple[str, ...]:
    """The strip's lines: the first :data:`MAX_WARNINGS` notes, then how many more."""
    lines = [f"note: {note}" for note in notes[:MAX_WARNINGS]]
    if len(notes) > MAX_WARNINGS:
        lines.append(f"and {len(notes) - MAX_WARNINGS} more lights whose shadows collapsed")
    return tuple(lines)


@dataclass
class BarSegment:
    """One pass's segment of the HUD's bar, window pixels."""

    name: str
    x0: float
    x1: float
    y0: float
    y1: float
    colour: tuple[float, float, float]   # RGB, 0..1


def hud_texts(figures: Figures, renderer: Renderer, soft: bool | None,
              hint: bool) -> tuple[str, str]:
    """The HUD's two lines: the figures, then the method and the lights (``hint``: and F1)."""
    total = figures.ms.get(TOTAL)
    fps = f"{figures.fps:.1f}" if figures.fps else "-"
    first = f"FPS {fps}  frame {total:.1f} ms" if total is not None else f"FPS {fps}"
    method = renderer.settings.method + (" + soft" if soft else "")
    if soft and figures.soft is not None:
        trace = figures.soft
        method += f" {trace.size[0]}x{trace.size[1]} {trace.ms:.1f} ms"
    lights = hud_lights(renderer.lights_on)
    if lights:
        method += f"  {lights}"
    return first, f"{method}  F1: panel" if hint else method


def hud_extent(texts: list[str], lines: int) -> tuple[float, float]:
    """The HUD's size at the current font size: as wide as the widest of ``texts``, with
    ``lines`` lines of text and the bar."""
    text_w = max(imgui.calc_text_size(text).x for text in texts)
    line_h = imgui.get_text_line_height()
    bar_h = HUD_BAR_HEIGHT * font_ratio()
    return (math.ceil(text_w + 2 * HUD_PADDING[0]),
            math.ceil(2 * HUD_PADDING[1] + lines * line_h + bar_h + lines * HUD_SPACING))


class Hud:
    """Builds the HUD; keeps what it drew last (tests read :attr:`lines` and :attr:`bar`)."""

    def __init__(self, history: PassHistory) -> None:
        self.history = history
        self.lines: tuple[str, ...] = ()      # the text as last drawn
        self.bar: list[BarSegment] = []       # the bar as last drawn
        self.warnings: tuple[str, ...] = ()   # the collapse strip as last drawn

    def draw(self, figures: Figures, renderer: Renderer, size: tuple[int, int],
             soft: bool | None, hint: bool) -> tuple[int, int, int, int]:
        """The HUD in the top-left corner of a window of ``size``; returns its x, y, w, h."""
        first, second = hud_texts(figures, renderer, soft, hint)
        budget = size[0] * size[1] * HUD_MAX_SHARE
        base = imgui.get_style().font_size_base
        # The fullest layout that fits: both lines, then the figures alone, in smaller fonts.
        layouts = [(1.0, True)] + [(step, False) for step in HUD_FONT_STEPS]
        for step, with_second in layouts:
            imgui.push_font(None, base * step)
            w, h = hud_extent([HUD_FPS_TEMPLATE, first] + ([second] if with_second else []),
                              2 if with_second else 1)
            imgui.pop_font()
            if w * h <= budget:
                break
        # A window too small for any of them: the box keeps to its share all the same.
        w = max(1, min(w, size[0] - 2 * PANEL_MARGIN))
        h = max(1, min(h, int(budget // w)))
        imgui.set_next_window_pos(imgui.ImVec2(PANEL_MARGIN, PANEL_MARGIN),
                                  imgui.Cond_.always.value)
        imgui.set_next_window_size(imgui.ImVec2(w, h), imgui.Cond_.always.value)
        imgui.set_next_window_bg_alpha(HUD_ALPHA)
        imgui.push_style_var(imgui.StyleVar_.window_padding.value, imgui.ImVec2(*HUD_PADDING))
        imgui.push_style_var(imgui.StyleVar_.item_spacing.value,
                             imgui.ImVec2(HUD_SPACING, HUD_SPACING))
        imgui.push_style_var(imgui.StyleVar_.window_min_size.value, imgui.ImVec2(1, 1))
        imgui.begin("hud", None, HUD_FLAGS)
        imgui.push_font(None, base * step)
        imgui.text(first)
        self._draw_bar(figures.ms, w - 2 * HUD_PADDING[0], HUD_BAR_HEIGHT * font_ratio())
        if with_second:
            imgui.text_disabled(second)
        imgui.pop_font()
        self.lines = (first, second) if with_second else (first,)
        rect = window_rect()
        imgui.end()
        imgui.pop_style_var(3)
        return rect

    def _draw_bar(self, ms: dict[str, float], width: float, height: float) -> None:
        """The frame's passes as one bar, each a segment as long as its share of the frame."""
        names = [n for n in self.history.names()
                 if n != TOTAL and n not in WINDOW_PASSES and ms.get(n) is not None]
        parts = [(n, max(0.0, ms[n])) for n in names]
        whole = max(ms.get(TOTAL) or 0.0, sum(v for _, v in parts))
        origin = imgui.get_cursor_screen_pos()
        draw_list = imgui.get_window_draw_list()
        draw_list.add_rect_filled(origin, imgui.ImVec2(origin.x + width, origin.y + height),
                                  imgui.get_color_u32(BAR_BACKGROUND))
        self.bar = []
        x = origin.x
        for name, value in parts:
            length = width * value / whole if whole > 0 else 0.0
            colour = self.history.colour(name)
            draw_list.add_rect_filled(imgui.ImVec2(x, origin.y),
                                      imgui.ImVec2(x + length, origin.y + height),
                                      imgui.get_color_u32(colour))
            self.bar.append(BarSegment(name, x, x + length, origin.y, origin.y + height,
                                       (colour.x, colour.y, colour.z)))
            x += length
        imgui.dummy(imgui.ImVec2(width, height))

    def draw_warnings(self, notes: list[str], size: tuple[int, int], left: int = 0) -> None:
        """The collapse notes in a strip along the bottom of a window of ``size``, right of
        ``left`` (the panel's edge) where that leaves it half the window (nothing where there
        are no notes)."""
        self.warnings = warning_lines(notes)
        if not self.warnings:
            return
        x = left + PANEL_MARGIN if size[0] - left >= size[0] / 2 else PANEL_MARGIN
        imgui.set_next_window_pos(imgui.ImVec2(x, size[1] - PANEL_MARGIN),
                                  imgui.Cond_.always.value, imgui.ImVec2(0.0, 1.0))
        # Height 0: as tall as the wrapped lines.
        imgui.set_next_window_size(imgui.ImVec2(max(1, size[0] - x - PANEL_MARGIN), 0),
                                   imgui.Cond_.always.value)
        imgui.set_next_window_bg_alpha(HUD_ALPHA)
        imgui.begin("collapse", None, HUD_FLAGS)
        imgui.push_style_color(imgui.Col_.text.value, WARNING_COLOUR)
        for line in self.warnings:
            imgui.text_wrapped(line)
        imgui.pop_style_color()
        imgui.end()
