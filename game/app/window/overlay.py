"""The timing overlay: imgui + implot through imgui-bundle's own GLFW and OpenGL3 backends.

It shows, every frame, the milliseconds of each pass now and as a rolling graph, the clock that
timed them, maps rendered and cached, triangles drawn into maps, maps read per shaded pixel and
the frame rate; and it edits the hard-shadow settings (the method among them, ``traced``
included), the sun, the debug view and, in a window, whether soft shadows are traced.

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
from game.app.window.settings_editor import SettingsEditor
from game.gpu.blocks import DEBUG_VIEWS
from game.render.renderer import Frame, Renderer
from game.shadows.plan import ShadowSettings

GLSL_VERSION = "#version 430"
HISTORY_FRAMES = 300               # frames in the rolling graph
PANEL_WIDTH = 400                  # pixels; the panel sits at the top-left corner
PANEL_MARGIN = 6
GRAPH_HEIGHT = 150
GRAPH_PERCENTILE = 98              # the y axis spans this percentile of the plotted ms ...
GRAPH_HEADROOM = 1.25              # ... times this
GRAPH_MIN_MS = 1.0
LABELLED_ITEM_WIDTH = 170          # pixels for a control, the rest of the row for its label
# Passes in display order; any other pass a renderer times follows them. The tracer's passes are
# prefixed ``traced_`` (the traced method) or ``soft_`` (soft shadows); ``composite`` lights the
# frame again through the traced visibility (game/render/traced_lighting.py).
PASS_ORDER = ("shadow_static", "shadow_dynamic", "cull", "shade", "traced_build", "traced_trace",
              "soft_build", "soft_trace", "composite")
HIDDEN_PASSES = ("readback", "gbuffer")
# The tracer's sub-totals and parts: counted in the passes above and in "total".
HIDDEN_SUFFIXES = ("_total", "_build_static", "_build_dynamic", "_trace_discarded")
# Window work after the scene's passes; shown after "total", which does not include them.
WINDOW_PASSES = ("present", "overlay")      # CPU copy for files, not part of drawing a frame
MIN_RENDER_SCALE = 0.25
TABS = ("view", "shadows", "maps")  # the tabs of controls under the figures
LAYER_VIEW_PIXELS = 200            # on-screen side of the layer viewer
MAP_LIST_HEIGHT = 110
RENDERED_COLOUR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)
CACHED_COLOUR = imgui.ImVec4(0.5, 0.95, 0.5, 1.0)


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

    @staticmethod
    def of(frame: Frame, clock: str, fps: float | None,
           maps_per_fragment: float | None = None) -> Figures:
        mpf = frame.maps_per_fragment
        return Figures(ms={k: v for k, v in frame.ms.items() if shown_pass(k)},
                       clock=clock, maps_rendered=frame.maps_rendered,
                       maps_cached=frame.maps_cached,
                       triangles_to_maps=frame.triangles_to_maps,
                       maps_per_fragment=mpf if mpf is not None else maps_per_fragment, fps=fps,
                       texels_to_maps=frame.texels_to_maps, characters=frame.characters)


@dataclass
class Changes:
    """What the user changed in the overlay this frame (None: unchanged)."""

    settings: ShadowSettings | None = None   # needs new maps
    light: object | None = None
    debug_view: str | None = None
    paused: bool | None = None
    render_scale: float | None = None
    soft: bool | None = None   # the window applies this one (it asks the renderer for it)

    def apply(self, renderer: Renderer) -> None:
        if self.settings is not None:
            renderer.set_settings(self.settings)
        if self.light is not None:
            renderer.set_light(self.light)
        if self.debug_view is not None:
            renderer.debug_view = self.debug_view


def shown_pass(name: str) -> bool:
    """Whether the panel lists a pass of the frame's times (sub-totals are left out)."""
    return name not in HIDDEN_PASSES and not name.endswith(HIDDEN_SUFFIXES)


def sun_angles(direction: np.ndarray) -> tuple[float, float]:
    """Azimuth (degrees clockwise from -Z seen from above) and elevation of the sun.

    ``direction`` is the way the light travels; the sun lies the other way.
    """
    s = -np.asarray(direction, float)
    s = s / np.linalg.norm(s)
    return (math.degrees(math.atan2(s[0], -s[2])),
            math.degrees(math.asin(float(np.clip(s[1], -1.0, 1.0)))))


def sun_direction(azimuth: float, elevation: float) -> np.ndarray:
    """The light's travel direction for a sun at ``azimuth``, ``elevation`` degrees."""
    a, e = math.radians(azimuth), math.radians(elevation)
    return -np.array([math.sin(a) * math.cos(e), math.sin(e), -math.cos(a) * math.cos(e)])


class Overlay:
    """The panel, drawn into whatever framebuffer is bound when :meth:`render` runs."""

    def __init__(self, window=None, open_tab: str = TABS[0]):
        """``window``: a glfw window whose context is current, or None to draw headless.

        ``open_tab`` is the tab of controls shown first (one of :data:`TABS`).
        """
        if open_tab not in TABS:
            raise ValueError(f"unknown overlay tab {open_tab!r}; valid: {', '.join(TABS)}")
        self.window = window
        self.open_tab = open_tab
        self._first_frame = True
        self.context = imgui.create_context()
        self.plot_context = implot.create_context()
        io = imgui.get_io()
        io.set_ini_filename("")  # no imgui.ini next to the user's files
        if window is not None:
            import ctypes

            ptr = ctypes.cast(window, ctypes.c_void_p).value
            imgui.backends.glfw_init_for_opengl(ptr, True)
        imgui.backends.opengl3_init(GLSL_VERSION)
        self.history = {}
        self.frames_seen = 0
        self.rect = (0, 0, 0, 0)   # x, y, w, h of the panel last drawn, window pixels
        self._azimuth_elevation: tuple[float, float] | None = None
        self._settings = SettingsEditor()
        self._viewer: LayerViewer | None = None
        self._map_index = 0
        self.message = ""   # the last change the renderer refused, shown in the panel

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

    def draw(self, figures: Figures, renderer: Renderer, paused: bool, size: tuple[int, int],
             dt: float | None = None, render_scale: float | None = None,
             soft: bool | None = None) -> Changes:
        """Build this frame's panel; ``size`` is the framebuffer's, ``dt`` the frame time.

        ``render_scale`` (the window's scene-to-window pixel ratio) adds a slider for it;
        ``soft`` (whether the window traces soft shadows) a checkbox.

        Call :meth:`render` afterwards to draw it into the bound framebuffer.
        """
        imgui.set_current_context(self.context)
        implot.set_current_context(self.plot_context)
        io = imgui.get_io()
        imgui.backends.opengl3_new_frame()
        if self.window is not None:
            imgui.backends.glfw_new_frame()
        else:
            io.display_size = imgui.ImVec2(float(size[0]), float(size[1]))
            io.delta_time = float(dt) if dt and dt > 0 else 1.0 / 30.0
        imgui.new_frame()
        self._record(figures.ms)
        changes = Changes()
        imgui.set_next_window_pos(imgui.ImVec2(PANEL_MARGIN, PANEL_MARGIN),
                                  imgui.Cond_.first_use_ever.value)
        # As tall as its contents, within the framebuffer; a fixed width.
        imgui.set_next_window_size_constraints(
            imgui.ImVec2(PANEL_WIDTH, 0),
            imgui.ImVec2(PANEL_WIDTH, max(1.0, size[1] - 2 * PANEL_MARGIN)))
        imgui.set_next_window_bg_alpha(0.8)
        imgui.begin("shadows", None, imgui.WindowFlags_.always_auto_resize.value)
        imgui.push_item_width(LABELLED_ITEM_WIDTH)
        self._draw_figures(figures)
        if self.message:
            imgui.text_colored(RENDERED_COLOUR, self.message)
        self._draw_graph()
        self._draw_controls(renderer, paused, render_scale, soft, changes)
        pos, extent = imgui.get_window_pos(), imgui.get_window_size()
        self.rect = (int(pos.x), int(pos.y), int(math.ceil(extent.x)), int(math.ceil(extent.y)))
        imgui.pop_item_width()
        imgui.end()
        imgui.render()
        return changes

    def render(self) -> None:
        """Draw the panel built by :meth:`draw` into the bound framebuffer."""
        imgui.set_current_context(self.context)
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())

    def _draw_figures(self, f: Figures) -> None:
        fps = f"{f.fps:.1f}" if f.fps else "-"
        if f.fps_from_total:
            fps += " (1000/total)"
        imgui.text(f"FPS {fps}   clock {f.clock}")
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
        imgui.text(f"maps rendered {f.maps_rendered}, cached {f.maps_cached}")
        imgui.text(f"triangles into maps {f.triangles_to_maps}, texels {f.texels_to_maps}")
        if f.characters:
            c = f.characters
            imgui.text(f"character maps {c['character_maps']}: skipped "
                       f"{c['characters_skipped']}, grouped {c['characters_grouped']}, "
                       f"shrunk {c['character_maps_shrunk']}")
        imgui.text(f"maps per fragment {mpf}")

    def _draw_graph(self) -> None:
        if not self.history:
            return
        if implot.begin_plot("ms per pass", imgui.ImVec2(-1, GRAPH_HEIGHT)):
            implot.setup_axes("", "ms", implot.AxisFlags_.no_tick_labels.value, 0)
            implot.setup_legend(implot.Location_.east.value, implot.LegendFlags_.outside.value)
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
            for name in self._pass_names():
                implot.plot_line(name, self.history[name])
            implot.end_plot()

    # -- controls -----------------------------------------------------------------------------
    def _draw_controls(self, renderer: Renderer, paused: bool, render_scale: float | None,
                       soft: bool | None, changes: Changes) -> None:
        if not imgui.begin_tab_bar("controls"):
            return
        if self._tab("view"):
            self._draw_view(renderer, paused, render_scale, soft, changes)
            imgui.end_tab_item()
        if self._tab("shadows"):
            self._settings.draw(renderer.settings, changes)
            for note in renderer.notes[-2:]:
                imgui.text_wrapped(f"note: {note}")
            imgui.end_tab_item()
        if self._tab("maps"):
            self._draw_maps(renderer)
            imgui.end_tab_item()
        imgui.end_tab_bar()
        self._first_frame = False

    def _draw_view(self, renderer: Renderer, paused: bool, render_scale: float | None,
                   soft: bool | None, changes: Changes) -> None:
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
        self._draw_sun(renderer, changes)
        if render_scale is not None:
            changed, scale = imgui.slider_float("render scale", render_scale, MIN_RENDER_SCALE,
                                                1.0, "%.2f")
            if changed:
                changes.render_scale = scale

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
        imgui.text(f"{rec.name}: layer {rec.layer}, {rec.viewport}^2 texels, "
                   f"{len(rec.objects)} object(s), {state}")
        if self._viewer is None:
            self._viewer = LayerViewer(renderer.ctx)
        self._viewer.draw(array, rec.layer, rec.viewport / array.resolution,
                          tuple(v / array.resolution for v in rec.origin))
        side = min(LAYER_VIEW_PIXELS, imgui.get_content_region_avail().x)
        # GL textures start at the bottom row: flip v.
        imgui.image(imgui.ImTextureRef(self._viewer.texture.glo), imgui.ImVec2(side, side),
                    imgui.ImVec2(0, 1), imgui.ImVec2(1, 0))
        # Every map this frame: red re-rendered, green served from the cache.
        if imgui.begin_child("map list", imgui.ImVec2(0, MAP_LIST_HEIGHT)):
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
        if self._azimuth_elevation is None:
            self._azimuth_elevation = sun_angles(light.direction)
        azimuth, elevation = self._azimuth_elevation
        a_changed, azimuth = imgui.slider_float("sun azimuth", azimuth, -180.0, 180.0, "%.1f deg")
        e_changed, elevation = imgui.slider_float("sun elevation", elevation, 1.0, 90.0,
                                                  "%.1f deg")
        if a_changed or e_changed:
            self._azimuth_elevation = (azimuth, elevation)
            changes.light = dataclasses.replace(light,
                                                direction=sun_direction(azimuth, elevation))

    def draw_over_frame(self, renderer: Renderer, frame: Frame, dt: float) -> np.ndarray:
        """Headless: draw the panel over the frame's picture (``renderer.display``) and read it
        back.

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

