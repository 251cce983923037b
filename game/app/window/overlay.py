"""The timing overlay: imgui + implot through imgui-bundle's own GLFW and OpenGL3 backends.

It has two modes. The HUD (the window's default) is a small corner box that covers at most
:data:`HUD_MAX_SHARE` of the window: the frame rate, the frame's milliseconds and a thin bar of
the passes, each a segment as long as its share of the frame. The panel (F1 in the window,
always in ``capture --overlay``) covers at most :data:`PANEL_MAX_SHARE` of the window, is sized
as a fraction of it, and scrolls what does not fit. The panel shows, every frame, the
milliseconds of each pass now and as a rolling graph, the clock that timed them, maps rendered
and cached, triangles drawn into maps, maps read per shaded pixel and the frame rate; and it
edits the hard-shadow settings (the method among them, ``traced`` included), the sun, the debug
view, the lights (each switched on or off, one moved: game/app/window/light_editor.py) and, in
a window, whether soft shadows are traced, and how (one pixel in how many, how many samples).
The HUD says how many lights there are when there are several, and with soft shadows on at what
resolution they were traced and in how many milliseconds.

The same overlay draws into a window (``window`` given: the GLFW backend feeds it input) or into
any framebuffer with no window at all (``capture --overlay``: display size and frame time are set
by hand). The controls are built from :class:`ShadowSettings`'s fields and the
method list, so settings and methods added later appear without edits here.

The overlay owns an imgui and an implot context and the OpenGL3 backend's GL objects (made in
the context current at construction); :meth:`Overlay.release` frees them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import imgui_bundle  # noqa: F401 - before glfw, so pyGLFW loads the GLFW 3.5 bundled with it
import numpy as np
from imgui_bundle import imgui, implot

from game.app.window.layer_view import LayerViewer
from game.app.window.light_editor import LABELS as LIGHT_LABELS
from game.app.window.light_editor import LightEditor, sun_angles, sun_direction
from game.app.window.settings_editor import SettingsEditor
from game.gpu.blocks import DEBUG_VIEWS
from game.render.renderer import Frame, Renderer
from game.scene.model import Light
from game.shadows.plan import ShadowSettings

GLSL_VERSION = "#version 430"
HISTORY_FRAMES = 300               # frames in the rolling graph
PANEL_MARGIN = 6                   # pixels between the overlay and the window's top-left corner
# The panel: a fraction of the window's width (no narrower than PANEL_MIN_WIDTH where the window
# allows), the window's height less the margins, and never more than PANEL_MAX_SHARE of the
# window's area (a narrow window gets a shorter panel). What does not fit scrolls.
PANEL_WIDTH_FRACTION = 0.3
PANEL_MIN_WIDTH = 240              # pixels
PANEL_MAX_SHARE = 1 / 3
PANEL_ALPHA = 0.8
# The HUD: one line of figures, the bar of the passes, a line with the method, the number of
# lights (where there are several) and the F1 hint (left out, and then the font shrunk, where
# the box would cover more than HUD_MAX_SHARE).
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
# The font is scaled with the window, relative to the size the overlay is laid out for.
REFERENCE_SIZE = (960, 540)
FONT_SCALE_RANGE = (0.75, 2.0)
GRAPH_HEIGHT = 150                 # pixels at font scale 1, without the legend above it
GRAPH_PERCENTILE = 98              # the y axis spans this percentile of the plotted ms ...
GRAPH_HEADROOM = 1.25              # ... times this
GRAPH_MIN_MS = 1.0
MIN_ITEM_FRACTION = 0.4            # of the panel's row: a control's least width beside its label
# Passes in display order; any other pass a renderer times follows them. The tracer's passes are
# prefixed ``traced_`` (the traced method) or ``soft_`` (soft shadows); ``composite`` lights the
# frame again through the traced visibility (game/render/traced_lighting.py).
PASS_ORDER = ("shadow_static", "shadow_dynamic", "cull", "shade", "traced_build", "traced_trace",
              "soft_build", "soft_trace", "soft_upsample", "composite")
HIDDEN_PASSES = ("readback", "gbuffer")
# The tracer's sub-totals and parts: counted in the passes above and in "total".
HIDDEN_SUFFIXES = ("_total", "_build_static", "_build_dynamic", "_trace_discarded")
# Window work after the scene's passes; shown after "total", which does not include them.
WINDOW_PASSES = ("present", "overlay")      # CPU copy for files, not part of drawing a frame
MIN_RENDER_SCALE = 0.25
TABS = ("view", "shadows", "lights", "maps")  # the tabs of controls under the figures
# The labels beside the controls of the view and maps tabs (their widths set the controls').
VIEW_LABELS = ("debug view", "sun azimuth", "sun elevation", "render scale", "trace divisor",
               "samples")
# The soft trace's controls: one traced pixel per N x N (1: every pixel), samples per point.
SOFT_DIVISOR_RANGE = (1, 8)
SOFT_SAMPLES_RANGE = (1, 32)
MAPS_LABELS = ("map",)
LAYER_VIEW_PIXELS = 200            # on-screen side of the layer viewer, at font scale 1
MAP_LIST_HEIGHT = 110              # pixels at font scale 1
RENDERED_COLOUR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)
CACHED_COLOUR = imgui.ImVec4(0.5, 0.95, 0.5, 1.0)
# One colour per pass, the same in the graph and in the HUD's bar: PASS_ORDER, "total" and
# WINDOW_PASSES in turn (Tableau 10 and two more); any other pass takes the next one round.
PASS_COLOURS = tuple(imgui.ImVec4(((c >> 16) & 255) / 255, ((c >> 8) & 255) / 255,
                                  (c & 255) / 255, 1.0)
                     for c in (0x4E79A7, 0xF28E2B, 0xE15759, 0x76B7B2, 0x59A14F, 0xEDC948,
                               0xB07AA1, 0xFF9DA7, 0x9C755F, 0xBAB0AC, 0xD37295, 0x8CD17D))
HUD_FLAGS = (imgui.WindowFlags_.no_title_bar.value | imgui.WindowFlags_.no_resize.value
             | imgui.WindowFlags_.no_move.value | imgui.WindowFlags_.no_scrollbar.value
             | imgui.WindowFlags_.no_saved_settings.value | imgui.WindowFlags_.no_inputs.value
             | imgui.WindowFlags_.no_focus_on_appearing.value)
# Sized by the window, not by its contents: those scroll up and down when they do not fit. Its
# rows fit its width (controls shrink beside their labels, text wraps) down to PANEL_MIN_WIDTH;
# only a narrower panel scrolls sideways too. (imgui's horizontal scrollbar stretches the rows
# that fill the width to the widest one seen, so it is not on where rows fit anyway.)
PANEL_FLAGS = (imgui.WindowFlags_.no_resize.value | imgui.WindowFlags_.no_move.value
               | imgui.WindowFlags_.no_collapse.value
               | imgui.WindowFlags_.no_saved_settings.value)


@dataclass
class SoftFigures:
    """The window's soft trace this frame: what the HUD and the panel say about it."""

    size: tuple[int, int]     # pixels traced, columns x rows
    divisor: int              # one traced pixel per divisor x divisor of the frame
    samples: int              # per traced pixel
    ms: float                 # the trace: its build and its dispatches
    state: str = ""           # accumulation, e.g. "still: 5/16 of round 1 of 2"


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
    characters: dict[str, int] | None = None  # the character maps (ShadowPlan.characters)
    soft: SoftFigures | None = None   # the window's soft trace, when soft shadows are on
    maps_waiting: int = 0             # view-sized clump maps whose new side waits

    @staticmethod
    def of(frame: Frame, clock: str, fps: float | None,
           maps_per_fragment: float | None = None) -> Figures:
        mpf = frame.maps_per_fragment
        return Figures(ms={k: v for k, v in frame.ms.items() if shown_pass(k)},
                       clock=clock, maps_rendered=frame.maps_rendered,
                       maps_cached=frame.maps_cached,
                       triangles_to_maps=frame.triangles_to_maps,
                       maps_per_fragment=mpf if mpf is not None else maps_per_fragment, fps=fps,
                       texels_to_maps=frame.texels_to_maps, characters=frame.characters,
                       maps_waiting=frame.maps_waiting)


@dataclass
class Changes:
    """What the user changed in the overlay this frame (None: unchanged)."""

    settings: ShadowSettings | None = None   # needs new maps
    # Lights moved, by index: only their maps are planned and drawn anew.
    lights: dict[int, Light] = dataclasses.field(default_factory=dict)
    lights_on: dict[int, bool] = dataclasses.field(default_factory=dict)  # switched, by index
    debug_view: str | None = None
    paused: bool | None = None
    render_scale: float | None = None
    soft: bool | None = None   # the window applies this one (it asks the renderer for it)
    soft_divisor: int | None = None   # the window's soft trace: one pixel in N x N ...
    soft_samples: int | None = None   # ... with this many samples
    selected_light: int | None = None   # the window keeps which light its keys move

    def apply(self, renderer: Renderer) -> None:
        if self.settings is not None:
            renderer.set_settings(self.settings)
        for index, light in self.lights.items():
            renderer.set_light(light, index)
        for index, on in self.lights_on.items():
            renderer.lights_on[index] = on
        if self.debug_view is not None:
            renderer.debug_view = self.debug_view


def shown_pass(name: str) -> bool:
    """Whether the panel lists a pass of the frame's times (sub-totals are left out)."""
    return name not in HIDDEN_PASSES and not name.endswith(HIDDEN_SUFFIXES)


def font_scale(size: tuple[int, int]) -> float:
    """The overlay's font scale in a window of ``size``: 1 at :data:`REFERENCE_SIZE`."""
    scale = min(size[0] / REFERENCE_SIZE[0], size[1] / REFERENCE_SIZE[1])
    return min(max(scale, FONT_SCALE_RANGE[0]), FONT_SCALE_RANGE[1])


def panel_extent(size: tuple[int, int]) -> tuple[int, int]:
    """The panel's width and height in a window of ``size``, pixels.

    A fraction of the window's width and its height less the margins, cut shorter where that
    would cover more than :data:`PANEL_MAX_SHARE` of the window.
    """
    room_w, room_h = max(1, size[0] - 2 * PANEL_MARGIN), max(1, size[1] - 2 * PANEL_MARGIN)
    width = int(min(room_w, max(PANEL_WIDTH_FRACTION * size[0], PANEL_MIN_WIDTH)))
    height = int(min(room_h, size[0] * size[1] * PANEL_MAX_SHARE / width))
    return width, max(1, height)


def hud_lights(lights_on: list[bool]) -> str:
    """The HUD's word on the lights: how many, and how many are off; nothing for one light."""
    if len(lights_on) < 2:
        return ""
    off = lights_on.count(False)
    return f"{len(lights_on)} lights" + (f", {off} off" if off else "")


@dataclass
class BarSegment:
    """One pass's segment of the HUD's bar, window pixels."""

    name: str
    x0: float
    x1: float
    y0: float
    y1: float
    colour: tuple[float, float, float]   # RGB, 0..1


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


class Overlay:
    """The HUD or the panel, drawn into whatever framebuffer is bound when :meth:`render` runs."""

    def __init__(self, window=None, open_tab: str = TABS[0], panel: bool = True):
        """``window``: a glfw window whose context is current, or None to draw headless.

        ``open_tab`` is the tab of controls shown first (one of :data:`TABS`); ``panel``
        whether the full panel is shown first rather than the HUD (:meth:`toggle_panel`).
        """
        if open_tab not in TABS:
            raise ValueError(f"unknown overlay tab {open_tab!r}; valid: {', '.join(TABS)}")
        self.window = window
        self.open_tab = open_tab
        self.panel = panel
        self._first_frame = True
        # Made current at once: imgui makes a new context current only where none is, and the
        # backends below belong to this one (another overlay may be alive).
        self.context = imgui.create_context()
        imgui.set_current_context(self.context)
        self.plot_context = implot.create_context()
        implot.set_current_context(self.plot_context)
        io = imgui.get_io()
        io.set_ini_filename("")  # no imgui.ini next to the user's files
        if window is not None:
            import ctypes

            ptr = ctypes.cast(window, ctypes.c_void_p).value
            imgui.backends.glfw_init_for_opengl(ptr, True)
        imgui.backends.opengl3_init(GLSL_VERSION)
        self.history = {}
        self.frames_seen = 0
        self.rect = (0, 0, 0, 0)   # x, y, w, h of the HUD or panel last drawn, window pixels
        self.bar: list[BarSegment] = []          # the HUD's bar as last drawn
        self.layout: PanelLayout | None = None   # the panel as last drawn
        self._colour_index = {name: i for i, name in
                              enumerate((*PASS_ORDER, "total", *WINDOW_PASSES))}
        # The sun sliders' angles and the direction they were taken from (or made).
        self._sun: tuple[np.ndarray, tuple[float, float]] | None = None
        self._settings = SettingsEditor()
        self.lights = LightEditor()
        self.hud_lines: tuple[str, ...] = ()      # the HUD's text as last drawn
        self._viewer: LayerViewer | None = None
        self._map_index = 0
        self.message = ""   # the last change the renderer refused, shown in the panel

    def toggle_panel(self) -> None:
        """Switch between the HUD and the full panel (F1 in the window)."""
        self.panel = not self.panel

    # -- input ------------------------------------------------------------------------------
    @property
    def wants_keyboard(self) -> bool:
        imgui.set_current_context(self.context)
        return imgui.get_io().want_capture_keyboard

    @property
    def wants_mouse(self) -> bool:
        imgui.set_current_context(self.context)
        return imgui.get_io().want_capture_mouse

    # -- one frame ----------------------------------------------------------------------------
    def _record(self, ms: dict[str, float]) -> None:
        for name, value in ms.items():
            if name not in self.history:
                self.history[name] = np.full(HISTORY_FRAMES, np.nan, np.float32)
            self.history[name][:-1] = self.history[name][1:]
            self.history[name][-1] = value
        for name, values in self.history.items():
            if name not in ms:
                values[:-1] = values[1:]
                values[-1] = np.nan
        self.frames_seen += 1

    def _pass_names(self) -> list[str]:
        known = [n for n in PASS_ORDER if n in self.history]
        others = sorted(n for n in self.history
                        if n not in PASS_ORDER and n not in WINDOW_PASSES and n != "total")
        window = [n for n in WINDOW_PASSES if n in self.history]
        return known + others + (["total"] if "total" in self.history else []) + window

    def pass_colour(self, name: str) -> imgui.ImVec4:
        """The colour of a pass, the same in the graph and the HUD's bar."""
        if name not in self._colour_index:
            self._colour_index[name] = len(self._colour_index)
        return PASS_COLOURS[self._colour_index[name] % len(PASS_COLOURS)]

    def draw(self, figures: Figures, renderer: Renderer, paused: bool, size: tuple[int, int],
             dt: float | None = None, render_scale: float | None = None,
             soft: bool | None = None, selected_light: int = 0) -> Changes:
        """Build this frame's HUD or panel; ``size`` is the framebuffer's, ``dt`` the frame
        time.

        ``render_scale`` (the window's scene-to-window pixel ratio) adds a slider for it;
        ``soft`` (whether the window traces soft shadows) a checkbox; ``selected_light`` is the
        light the lights tab moves.

        Call :meth:`render` afterwards to draw it into the bound framebuffer.
        """
        imgui.set_current_context(self.context)
        implot.set_current_context(self.plot_context)
        io = imgui.get_io()
        imgui.get_style().font_scale_main = font_scale(size)
        imgui.backends.opengl3_new_frame()
        if self.window is not None:
            imgui.backends.glfw_new_frame()
        else:
            io.display_size = imgui.ImVec2(float(size[0]), float(size[1]))
            io.delta_time = float(dt) if dt and dt > 0 else 1.0 / 30.0
        imgui.new_frame()
        self._record(figures.ms)
        changes = Changes()
        if self.panel:
            self._draw_panel(figures, renderer, paused, size, render_scale, soft,
                             selected_light, changes)
        else:
            self._draw_hud(figures, renderer, size, soft)
        imgui.render()
        return changes

    def render(self) -> None:
        """Draw the HUD or panel built by :meth:`draw` into the bound framebuffer."""
        imgui.set_current_context(self.context)
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())

    def _keep_rect(self) -> None:
        pos, extent = imgui.get_window_pos(), imgui.get_window_size()
        self.rect = (int(pos.x), int(pos.y), int(math.ceil(extent.x)), int(math.ceil(extent.y)))

    # -- the HUD ------------------------------------------------------------------------------
    def _hud_extent(self, texts: list[str], lines: int) -> tuple[float, float]:
        """The HUD's size at the current font size: as wide as the widest of ``texts``, with
        ``lines`` lines of text and the bar."""
        text_w = max(imgui.calc_text_size(text).x for text in texts)
        line_h = imgui.get_text_line_height()
        bar_h = HUD_BAR_HEIGHT * self._font_ratio()
        return (math.ceil(text_w + 2 * HUD_PADDING[0]),
                math.ceil(2 * HUD_PADDING[1] + lines * line_h + bar_h + lines * HUD_SPACING))

    def _draw_hud(self, figures: Figures, renderer: Renderer, size: tuple[int, int],
                  soft: bool | None) -> None:
        """The frame rate, the frame's ms and the bar of the passes, in a corner box that
        covers at most :data:`HUD_MAX_SHARE` of the window."""
        total = figures.ms.get("total")
        fps = f"{figures.fps:.1f}" if figures.fps else "-"
        first = f"FPS {fps}  frame {total:.1f} ms" if total is not None else f"FPS {fps}"
        method = renderer.settings.method + (" + soft" if soft else "")
        if soft and figures.soft is not None:
            trace = figures.soft
            method += f" {trace.size[0]}x{trace.size[1]} {trace.ms:.1f} ms"
        lights = hud_lights(renderer.lights_on)
        if lights:
            method += f"  {lights}"
        second = f"{method}  F1: panel" if self.window is not None else method
        budget = size[0] * size[1] * HUD_MAX_SHARE
        base = imgui.get_style().font_size_base
        # The fullest layout that fits: both lines, then the figures alone, in smaller fonts.
        layouts = [(1.0, True)] + [(step, False) for step in HUD_FONT_STEPS]
        for step, with_second in layouts:
            imgui.push_font(None, base * step)
            w, h = self._hud_extent([HUD_FPS_TEMPLATE, first] + ([second] if with_second else []),
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
        self._draw_bar(figures.ms, w - 2 * HUD_PADDING[0], HUD_BAR_HEIGHT * self._font_ratio())
        if with_second:
            imgui.text_disabled(second)
        imgui.pop_font()
        self.hud_lines = (first, second) if with_second else (first,)
        self._keep_rect()
        imgui.end()
        imgui.pop_style_var(3)

    def _draw_bar(self, ms: dict[str, float], width: float, height: float) -> None:
        """The frame's passes as one bar, each a segment as long as its share of the frame."""
        names = [n for n in self._pass_names()
                 if n != "total" and n not in WINDOW_PASSES and ms.get(n) is not None]
        parts = [(n, max(0.0, ms[n])) for n in names]
        whole = max(ms.get("total") or 0.0, sum(v for _, v in parts))
        origin = imgui.get_cursor_screen_pos()
        draw_list = imgui.get_window_draw_list()
        draw_list.add_rect_filled(origin, imgui.ImVec2(origin.x + width, origin.y + height),
                                  imgui.get_color_u32(BAR_BACKGROUND))
        self.bar = []
        x = origin.x
        for name, value in parts:
            length = width * value / whole if whole > 0 else 0.0
            colour = self.pass_colour(name)
            draw_list.add_rect_filled(imgui.ImVec2(x, origin.y),
                                      imgui.ImVec2(x + length, origin.y + height),
                                      imgui.get_color_u32(colour))
            self.bar.append(BarSegment(name, x, x + length, origin.y, origin.y + height,
                                       (colour.x, colour.y, colour.z)))
            x += length
        imgui.dummy(imgui.ImVec2(width, height))

    # -- the panel ----------------------------------------------------------------------------
    def _draw_panel(self, figures: Figures, renderer: Renderer, paused: bool,
                    size: tuple[int, int], render_scale: float | None, soft: bool | None,
                    selected_light: int, changes: Changes) -> None:
        w, h = panel_extent(size)
        imgui.set_next_window_pos(imgui.ImVec2(PANEL_MARGIN, PANEL_MARGIN),
                                  imgui.Cond_.always.value)
        imgui.set_next_window_size(imgui.ImVec2(w, h), imgui.Cond_.always.value)
        imgui.set_next_window_bg_alpha(PANEL_ALPHA)
        title = "shadows  (F1: HUD)" if self.window is not None else "shadows"
        sideways = imgui.WindowFlags_.horizontal_scrollbar.value if w < PANEL_MIN_WIDTH else 0
        imgui.begin(f"{title}###shadows", None, PANEL_FLAGS | sideways)
        self._draw_figures(figures)
        if soft and figures.soft is not None:
            self._draw_soft(figures.soft)
        if self.message:
            imgui.text_colored(RENDERED_COLOUR, self.message)
        legend = self._draw_graph()
        self._draw_controls(renderer, paused, render_scale, soft, selected_light, changes,
                            figures.soft)
        self._keep_rect()
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

    def _draw_figures(self, f: Figures) -> None:
        fps = f"{f.fps:.1f}" if f.fps else "-"
        if f.fps_from_total:
            fps += " (1000/total)"
        imgui.text_wrapped(f"FPS {fps}   clock {f.clock}")
        if imgui.begin_table("passes", 2):
            for name in self._pass_names():
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text(name)
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
            imgui.text_wrapped(f"character maps {c['character_maps']}: skipped "
                               f"{c['characters_skipped']}, grouped "
                               f"{c['characters_grouped']}, shrunk "
                               f"{c['character_maps_shrunk']}")
        imgui.text_wrapped(f"maps per fragment {mpf}")

    @staticmethod
    def _draw_soft(trace: SoftFigures) -> None:
        """The soft trace: its resolution, its share of the pixels, its samples and time."""
        share = "every pixel" if trace.divisor == 1 else \
            f"1 in {trace.divisor}x{trace.divisor} pixels"
        imgui.text_wrapped(f"soft trace {trace.size[0]}x{trace.size[1]} ({share}), "
                           f"{trace.samples} samples: {trace.ms:.1f} ms")
        if trace.state:
            imgui.text_wrapped(trace.state)

    def _graph_height(self, entries: int) -> float:
        """The plot's height: its legend of ``entries`` lines above a plot area of
        :data:`GRAPH_HEIGHT` (both scaled with the font)."""
        style, line_h = implot.get_style(), imgui.get_text_line_height()
        legend = (entries * line_h + (entries - 1) * style.legend_spacing.y
                  + 2 * style.legend_inner_padding.y + style.legend_padding.y)
        return math.ceil(GRAPH_HEIGHT * self._font_ratio() + legend)

    def _draw_graph(self) -> tuple[tuple, tuple] | None:
        """The rolling graph; returns its legend's rectangle whole and as shown."""
        if not self.history:
            return None
        names = self._pass_names()
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
        recent = np.concatenate([v for v in self.history.values()])
        recent = recent[np.isfinite(recent)]
        top = float(np.percentile(recent, GRAPH_PERCENTILE)) if len(recent) else 1.0
        implot.setup_axis_limits(implot.ImAxis_.y1.value, 0.0,
                                 max(GRAPH_MIN_MS, top * GRAPH_HEADROOM),
                                 implot.Cond_.always.value)
        for name in names:
            spec = implot.Spec()
            spec.line_color = self.pass_colour(name)
            implot.plot_line(name, self.history[name], spec=spec)
        implot.end_plot()
        legend = plot.items.legend

        def corners(rect) -> tuple[float, float, float, float]:
            return (rect.min.x, rect.min.y, rect.max.x, rect.max.y)

        return corners(legend.rect), corners(legend.rect_clamped)

    # -- controls -----------------------------------------------------------------------------
    def _draw_controls(self, renderer: Renderer, paused: bool, render_scale: float | None,
                       soft: bool | None, selected_light: int, changes: Changes,
                       trace: SoftFigures | None = None) -> None:
        if not imgui.begin_tab_bar("controls"):
            return
        if self._tab("view"):
            self._push_item_width(VIEW_LABELS)
            self._draw_view(renderer, paused, render_scale, soft, changes, trace)
            imgui.pop_item_width()
            imgui.end_tab_item()
        if self._tab("shadows"):
            self._push_item_width(self._settings.labels(renderer.settings))
            self._settings.draw(renderer.settings, changes)
            imgui.pop_item_width()
            for note in renderer.notes[-2:]:
                imgui.text_wrapped(f"note: {note}")
            imgui.end_tab_item()
        if self._tab("lights"):
            self._push_item_width(LIGHT_LABELS)
            self.lights.draw(renderer, selected_light, changes)
            imgui.pop_item_width()
            imgui.end_tab_item()
        if self._tab("maps"):
            self._push_item_width(MAPS_LABELS)
            self._draw_maps(renderer)
            imgui.pop_item_width()
            imgui.end_tab_item()
        imgui.end_tab_bar()
        self._first_frame = False

    @staticmethod
    def _push_item_width(labels) -> None:
        """Controls as wide as the row less the longest label beside them (so that no label
        runs past the panel), but no narrower than :data:`MIN_ITEM_FRACTION` of the row."""
        avail = imgui.get_content_region_avail().x
        label = (max(imgui.calc_text_size(text).x for text in labels)
                 + imgui.get_style().item_inner_spacing.x)
        # Negative: up to that far from the row's right edge, also after a checkbox on the row.
        imgui.push_item_width(-label if avail - label >= MIN_ITEM_FRACTION * avail
                              else MIN_ITEM_FRACTION * avail)

    def _draw_view(self, renderer: Renderer, paused: bool, render_scale: float | None,
                   soft: bool | None, changes: Changes, trace: SoftFigures | None) -> None:
        changed, value = imgui.checkbox("pause characters (P)", paused)
        if changed:
            changes.paused = value
        views = list(DEBUG_VIEWS)
        changed, index = imgui.combo("debug view", views.index(renderer.debug_view), views)
        if changed:
            changes.debug_view = views[index]
        if soft is not None and renderer.scene.linear_light is None:
            imgui.text_disabled("soft shadows: the scene has no [linear_light]")
        elif soft is not None:
            changed, value = imgui.checkbox("soft shadows (linear light)", soft)
            if changed:
                changes.soft = value
            if soft and trace is not None:
                changed, divisor = imgui.slider_int("trace divisor", trace.divisor,
                                                    *SOFT_DIVISOR_RANGE, "1 in %d per side")
                if changed:
                    changes.soft_divisor = divisor
                changed, samples = imgui.slider_int("samples", trace.samples,
                                                    *SOFT_SAMPLES_RANGE)
                if changed:
                    changes.soft_samples = samples
        self._draw_sun(renderer, changes)
        if render_scale is not None:
            changed, scale = imgui.slider_float("render scale", render_scale, MIN_RENDER_SCALE,
                                                1.0, "%.2f")
            if changed:
                changes.render_scale = scale

    @staticmethod
    def _font_ratio() -> float:
        """The font's size now over its size at scale 1: pixel sizes grow with it."""
        return imgui.get_font_size() / imgui.get_style().font_size_base

    def _tab(self, name: str) -> bool:
        flags = (imgui.TabItemFlags_.set_selected.value
                 if self._first_frame and name == self.open_tab else 0)
        return imgui.begin_tab_item(name, None, flags)[0]

    def _draw_maps(self, renderer: Renderer) -> None:
        """The maps of the last frame, cached or re-rendered, and a viewer of one layer."""
        plan, array = renderer.last_plan, renderer.shadow_array
        if plan is None or array is None or not plan.maps:
            imgui.text("no shadow maps yet")
            return
        rendered = set(plan.render_static) | set(plan.render_dynamic)
        self._map_index = min(self._map_index, len(plan.maps) - 1)
        _, self._map_index = imgui.slider_int("map", self._map_index, 0, len(plan.maps) - 1)
        rec = plan.maps[self._map_index]
        state = "re-rendered" if self._map_index in rendered else "cached"
        imgui.text_wrapped(f"{rec.name}: layer {rec.layer}, {rec.viewport}^2 texels, "
                           f"{len(rec.objects)} object(s), {state}")
        if self._viewer is None:
            self._viewer = LayerViewer(renderer.ctx)
        self._viewer.draw(array, rec.layer, rec.viewport / array.resolution,
                          tuple(v / array.resolution for v in rec.origin))
        side = min(LAYER_VIEW_PIXELS * self._font_ratio(), imgui.get_content_region_avail().x)
        # GL textures start at the bottom row: flip v.
        imgui.image(imgui.ImTextureRef(self._viewer.texture.glo), imgui.ImVec2(side, side),
                    imgui.ImVec2(0, 1), imgui.ImVec2(1, 0))
        # Every map this frame: red re-rendered, green served from the cache.
        if imgui.begin_child("map list", imgui.ImVec2(0, MAP_LIST_HEIGHT * self._font_ratio()),
                             0, imgui.WindowFlags_.horizontal_scrollbar.value):
            for i, m in enumerate(plan.maps):
                fresh = i in rendered
                imgui.text_colored(RENDERED_COLOUR if fresh else CACHED_COLOUR,
                                   f"{i:3d} {m.name:<14} layer {m.layer:3d} "
                                   f"{'re-rendered' if fresh else 'cached'}")
        imgui.end_child()

    def _draw_sun(self, renderer: Renderer, changes: Changes) -> None:
        light = renderer.scene.light
        if light.kind != "directional":
            imgui.text(f"light: {light.kind} (sun controls need a directional light)")
            return
        # Taken again from the light when something else turned it (the lights tab, a key).
        if self._sun is None or not np.array_equal(self._sun[0], light.direction):
            self._sun = (light.direction, sun_angles(light.direction))
        azimuth, elevation = self._sun[1]
        a_changed, azimuth = imgui.slider_float("sun azimuth", azimuth, -180.0, 180.0, "%.1f deg")
        e_changed, elevation = imgui.slider_float("sun elevation", elevation, 1.0, 90.0,
                                                  "%.1f deg")
        if a_changed or e_changed:
            direction = sun_direction(azimuth, elevation)
            self._sun = (direction, (azimuth, elevation))
            changes.lights[0] = dataclasses.replace(light, direction=direction)

    def draw_over_frame(self, renderer: Renderer, frame: Frame, dt: float) -> np.ndarray:
        """Headless: draw the panel (or the HUD) over the frame's picture
        (``renderer.display``) and read it back.

        The frame rate shown is ``1000 / total`` ms, the rate this frame's work alone would allow.
        """
        total = frame.ms.get("total")
        figures = Figures.of(frame, renderer.timer.clock, 1e3 / total if total else None)
        figures.fps_from_total = True
        first = self.frames_seen == 0
        self.draw(figures, renderer, False, renderer.size, dt)
        if first:
            # imgui measures an auto-resized window in its first frame and shows it from the
            # second: build the first frame twice, so that frame 0 of a capture has its panel.
            self.history.clear()
            self.frames_seen = 0
            self.draw(figures, renderer, False, renderer.size, dt)
        framebuffer, _ = renderer.display
        framebuffer.use()
        self.render()
        w, h = renderer.size
        data = framebuffer.read(viewport=(0, 0, w, h), components=3, attachment=0)
        return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()

    def release(self) -> None:
        """Free the backends' GL objects and the imgui and implot contexts."""
        if self.context is None:
            return
        imgui.set_current_context(self.context)
        if self._viewer is not None:
            self._viewer.release()
            self._viewer = None
        imgui.backends.opengl3_shutdown()
        if self.window is not None:
            imgui.backends.glfw_shutdown()
        implot.destroy_context(self.plot_context)
        imgui.destroy_context(self.context)
        self.context = None

