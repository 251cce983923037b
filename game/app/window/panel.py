"""The overlay's full panel (F1 in the window, always in ``capture --overlay``).

It covers at most :data:`PANEL_MAX_SHARE` of the window, is sized as a fraction of it, and
scrolls what does not fit. It shows, every frame, the milliseconds of each pass now and as a
rolling graph, the clock that timed them, maps rendered and cached, triangles drawn into maps,
maps read per shaded pixel and the frame rate; with soft shadows on, the trace's resolution,
samples and time. Under them a tab per kind of control: the view (game/app/window/view_tab.py),
the hard-shadow settings (game/app/window/settings_editor.py), the lights
(game/app/window/light_editor.py) and the maps (game/app/window/maps_tab.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from imgui_bundle import imgui, implot

from game.app.window import light_editor, maps_tab, view_tab
from game.app.window.changes import Changes
from game.app.window.figures import HISTORY_FRAMES, Figures, PassHistory, SoftFigures
from game.app.window.imgui_layout import PANEL_MARGIN, font_ratio, push_item_width, window_rect
from game.app.window.light_editor import LightEditor
from game.app.window.maps_tab import MapsTab
from game.app.window.settings_editor import SettingsEditor
from game.app.window.view_tab import ViewTab
from game.render.passes import SHADE

if TYPE_CHECKING:
    from game.render.renderer import Renderer

# A fraction of the window's width (no narrower than PANEL_MIN_WIDTH where the window allows),
# the window's height less the margins, and never more than PANEL_MAX_SHARE of the window's area
# (a narrow window gets a shorter panel). What does not fit scrolls.
PANEL_WIDTH_FRACTION = 0.3
PANEL_MIN_WIDTH = 240              # pixels
PANEL_MAX_SHARE = 1 / 3
PANEL_ALPHA = 0.8
GRAPH_HEIGHT = 150                 # pixels at font scale 1, without the legend above it
GRAPH_PERCENTILE = 98              # the y axis spans this percentile of the plotted ms ...
GRAPH_HEADROOM = 1.25              # ... times this
GRAPH_MIN_MS = 1.0
TABS = ("view", "shadows", "lights", "maps")  # the tabs of controls under the figures
REFUSED_COLOUR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)   # a change the renderer refused
# Sized by the window, not by its contents: those scroll up and down when they do not fit. Its
# rows fit its width (controls shrink beside their labels, text wraps) down to PANEL_MIN_WIDTH;
# only a narrower panel scrolls sideways too. (imgui's horizontal scrollbar stretches the rows
# that fill the width to the widest one seen, so it is not on where rows fit anyway.)
PANEL_FLAGS = (imgui.WindowFlags_.no_resize.value | imgui.WindowFlags_.no_move.value
               | imgui.WindowFlags_.no_collapse.value
               | imgui.WindowFlags_.no_saved_settings.value)


def panel_extent(size: tuple[int, int]) -> tuple[int, int]:
    """The panel's width and height in a window of ``size``, pixels.

    A fraction of the window's width and its height less the margins, cut shorter where that
    would cover more than :data:`PANEL_MAX_SHARE` of the window.
    """
    room_w, room_h = max(1, size[0] - 2 * PANEL_MARGIN), max(1, size[1] - 2 * PANEL_MARGIN)
    width = int(min(room_w, max(PANEL_WIDTH_FRACTION * size[0], PANEL_MIN_WIDTH)))
    height = int(min(room_h, size[0] * size[1] * PANEL_MAX_SHARE / width))
    return width, max(1, height)


@dataclass
class PanelLayout:
    """How the panel's content sat in it when it was last drawn, window pixels (tests read it).

    ``content`` is imgui's measure of everything the panel holds, ``inner`` the room inside
    its borders and scrollbars, ``padding`` the margin inside that room, ``scroll_max`` how far
    it scrolls and ``scrollbars`` whether each scrollbar (x, y) is shown; ``legend`` and
    ``legend_shown`` are the graph's legend whole and as far as its plot shows it
    (x0, y0, x1, y1).
    """

    content: tuple[float, float]
    inner: tuple[float, float]
    scroll_max: tuple[float, float]
    scrollbars: tuple[bool, bool]
    padding: tuple[float, float]
    legend: tuple[float, float, float, float] | None = None
    legend_shown: tuple[float, float, float, float] | None = None


@dataclass
class WindowState:
    """What the window shows the panel of its own state (None: the panel has no control for
    it, as headless)."""

    paused: bool
    render_scale: float | None = None
    soft: bool | None = None
    selected_light: int = 0      # the light the lights tab moves


class Panel:
    """Builds the panel; its tabs keep their own state between frames."""

    def __init__(self, history: PassHistory, open_tab: str = TABS[0]) -> None:
        """``open_tab`` is the tab of controls shown first (one of :data:`TABS`)."""
        if open_tab not in TABS:
            raise ValueError(f"unknown overlay tab {open_tab!r}; valid: {', '.join(TABS)}")
        self.history = history
        self.open_tab = open_tab
        self._first_frame = True
        self.view = ViewTab()
        self.settings = SettingsEditor()
        self.lights = LightEditor()
        self.maps = MapsTab()
        self.layout: PanelLayout | None = None   # the panel as last drawn

    def draw(self, figures: Figures, renderer: Renderer, size: tuple[int, int],
             state: WindowState, changes: Changes, message: str = "",
             title: str = "shadows") -> tuple[int, int, int, int]:
        """The panel in the top-left corner of a window of ``size``, ``message`` (a change the
        renderer refused) under its figures; returns its x, y, w, h."""
        w, h = panel_extent(size)
        imgui.set_next_window_pos(imgui.ImVec2(PANEL_MARGIN, PANEL_MARGIN),
                                  imgui.Cond_.always.value)
        imgui.set_next_window_size(imgui.ImVec2(w, h), imgui.Cond_.always.value)
        imgui.set_next_window_bg_alpha(PANEL_ALPHA)
        sideways = imgui.WindowFlags_.horizontal_scrollbar.value if w < PANEL_MIN_WIDTH else 0
        imgui.begin(f"{title}###shadows", None, PANEL_FLAGS | sideways)
        draw_figures(figures, self.history.names())
        if state.soft and figures.soft is not None:
            draw_soft(figures.soft)
        if message:
            imgui.text_colored(REFUSED_COLOUR, message)
        legend = self._draw_graph()
        self._draw_controls(renderer, state, changes, figures.soft)
        rect = window_rect()
        window = imgui.internal.get_current_window()
        inner = window.inner_rect
        self.layout = PanelLayout(
            content=(window.content_size.x, window.content_size.y),
            inner=(inner.get_width(), inner.get_height()),
            scroll_max=(window.scroll_max.x, window.scroll_max.y),
            scrollbars=(window.scrollbar_x, window.scrollbar_y),
            padding=(window.window_padding.x, window.window_padding.y),
            legend=legend[0] if legend else None, legend_shown=legend[1] if legend else None)
        imgui.end()
        return rect

    # -- the graph ----------------------------------------------------------------------------
    @staticmethod
    def _graph_height(entries: int) -> float:
        """The plot's height: its legend of ``entries`` lines above a plot area of
        :data:`GRAPH_HEIGHT` (both scaled with the font)."""
        style, line_h = implot.get_style(), imgui.get_text_line_height()
        legend = (entries * line_h + (entries - 1) * style.legend_spacing.y
                  + 2 * style.legend_inner_padding.y + style.legend_padding.y)
        return math.ceil(GRAPH_HEIGHT * font_ratio() + legend)

    def _draw_graph(self) -> tuple[tuple, tuple] | None:
        """The rolling graph; returns its legend's rectangle whole and as shown."""
        history = self.history.ms
        if not history:
            return None
        names = self.history.names()
        # The legend goes above the plot, not beside it: the plot keeps the panel's width, and
        # the plot is made taller by the legend's height, so that implot never clips it.
        imgui.text("ms per pass")
        if not implot.begin_plot("##ms per pass",
                                 imgui.ImVec2(-1, self._graph_height(len(names))),
                                 implot.Flags_.no_title.value):
            return None
        plot = implot.internal.get_current_plot()
        implot.setup_axes("", "ms", implot.AxisFlags_.no_tick_labels.value, 0)
        implot.setup_legend(implot.Location_.north.value, implot.LegendFlags_.outside.value)
        implot.setup_axis_limits(implot.ImAxis_.x1.value, 0, HISTORY_FRAMES,
                                 implot.Cond_.always.value)
        # Fit the y axis to the usual frames, not to a one-off spike (the first frame
        # compiles shaders and renders every map).
        recent = np.concatenate([v for v in history.values()])
        recent = recent[np.isfinite(recent)]
        top = float(np.percentile(recent, GRAPH_PERCENTILE)) if len(recent) else 1.0
        implot.setup_axis_limits(implot.ImAxis_.y1.value, 0.0,
                                 max(GRAPH_MIN_MS, top * GRAPH_HEADROOM),
                                 implot.Cond_.always.value)
        for name in names:
            spec = implot.Spec()
            spec.line_color = self.history.colour(name)
            implot.plot_line(name, history[name], spec=spec)
        implot.end_plot()
        legend = plot.items.legend

        def corners(rect) -> tuple[float, float, float, float]:
            return (rect.min.x, rect.min.y, rect.max.x, rect.max.y)

        return corners(legend.rect), corners(legend.rect_clamped)

    # -- the controls -------------------------------------------------------------------------
    def _draw_controls(self, renderer: Renderer, state: WindowState, changes: Changes,
                       trace: SoftFigures | None) -> None:
        if not imgui.begin_tab_bar("controls"):
            return
        if self._tab("view"):
            push_item_width(view_tab.LABELS)
            self.view.draw(renderer, state.paused, state.render_scale, state.soft, changes,
                           trace)
            imgui.pop_item_width()
            imgui.end_tab_item()
        if self._tab("shadows"):
            push_item_width(self.settings.labels(renderer.settings))
            self.settings.draw(renderer.settings, changes)
            imgui.pop_item_width()
            for note in renderer.notes[-2:]:
                imgui.text_wrapped(f"note: {note}")
            imgui.end_tab_item()
        if self._tab("lights"):
            push_item_width(light_editor.LABELS)
            self.lights.draw(renderer, state.selected_light, changes)
            imgui.pop_item_width()
            imgui.end_tab_item()
        if self._tab("maps"):
            push_item_width(maps_tab.LABELS)
            self.maps.draw(renderer)
            imgui.pop_item_width()
            imgui.end_tab_item()
        imgui.end_tab_bar()
        self._first_frame = False

    def _tab(self, name: str) -> bool:
        flags = (imgui.TabItemFlags_.set_selected.value
                 if self._first_frame and name == self.open_tab else 0)
        return imgui.begin_tab_item(name, None, flags)[0]

    def release(self) -> None:
        self.maps.release()


def draw_figures(f: Figures, names: list[str]) -> None:
    """The frame rate and clock, the ms of the passes ``names``, and the maps' counts."""
    fps = f"{f.fps:.1f}" if f.fps else "-"
    if f.fps_from_total:
        fps += " (1000/total)"
    imgui.text_wrapped(f"FPS {fps}   clock {f.clock}")
    if imgui.begin_table("passes", 2):
        for name in names:
            imgui.table_next_row()
            imgui.table_next_column()
            # The shading pass's time holds a depth-only pass where it drew one.
            imgui.text(f"{name}, depth first" if name == SHADE and f.depth_first else name)
            imgui.table_next_column()
            value = f.ms.get(name)
            imgui.text(f"{value:7.2f} ms" if value is not None else "      -")
        imgui.end_table()
    mpf = f"{f.maps_per_fragment:.3f}" if f.maps_per_fragment is not None else "-"
    imgui.text_wrapped(f"maps rendered {f.maps_rendered}, cached {f.maps_cached}"
                       + (f", waiting {f.maps_waiting}" if f.maps_waiting else ""))
    imgui.text_wrapped(f"triangles into maps {f.triangles_to_maps}, "
                       f"texels {f.texels_to_maps}")
    if f.characters:
        c = f.characters
        imgui.text_wrapped(f"character maps {c.maps}: skipped {c.skipped}, grouped "
                           f"{c.grouped}, shrunk {c.shrunk}")
    imgui.text_wrapped(f"maps per fragment {mpf}")
    if f.map_candidates_per_fragment is not None:
        imgui.text_wrapped(f"map candidates per fragment {f.map_candidates_per_fragment:.3f}")


def draw_soft(trace: SoftFigures) -> None:
    """The soft trace: its resolution, its share of the pixels, its samples and time."""
    share = "every pixel" if trace.divisor == 1 else \
        f"1 in {trace.divisor}x{trace.divisor} pixels"
    imgui.text_wrapped(f"soft trace {trace.size[0]}x{trace.size[1]} ({share}), "
                       f"{trace.samples} {trace.unit}: {trace.ms:.1f} ms")
    if trace.state:
        imgui.text_wrapped(trace.state)
