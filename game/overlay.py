"""The timing overlay: imgui + implot through imgui-bundle's own GLFW and OpenGL3 backends.

It shows, every frame, the milliseconds of each pass now and as a rolling graph, the clock that
timed them, maps rendered and cached, triangles drawn into maps, maps read per shaded pixel and
the frame rate; and it edits the hard-shadow settings, the sun and the debug view.

The same overlay draws into a window (``window`` given: the GLFW backend feeds it input) or into
any framebuffer with no window at all (``capture --overlay``: display size and frame time are set
by hand). The controls are built from :class:`shadow_methods.ShadowSettings`'s fields and the
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

from . import shadow_methods
from .renderer import DEBUG_VIEWS, Frame, Renderer

GLSL_VERSION = "#version 430"
HISTORY_FRAMES = 300               # frames in the rolling graph
PANEL_WIDTH = 400                  # pixels; the panel sits at the top-left corner
PANEL_MARGIN = 6
GRAPH_HEIGHT = 150
GRAPH_PERCENTILE = 98              # the y axis spans this percentile of the plotted ms ...
GRAPH_HEADROOM = 1.25              # ... times this
GRAPH_MIN_MS = 1.0
LABELLED_ITEM_WIDTH = 170          # pixels for a control, the rest of the row for its label
# Passes in display order; any other pass a renderer times (a soft trace, say) follows them.
PASS_ORDER = ("shadow_static", "shadow_dynamic", "shade", "soft", "trace")
HIDDEN_PASSES = ("readback",)
# Window work after the scene's passes; shown after "total", which does not include them.
WINDOW_PASSES = ("present", "overlay")      # CPU copy for files, not part of drawing a frame
RESOLUTIONS = (128, 256, 512, 1024, 2048, 4096, 8192)
# Settings read only by the shading pass: edited in place, no re-clumping, maps stay cached.
SHADING_ONLY = {"normal_bias", "depth_bias", "slope_bias", "max_slope", "pcf"}
SETTING_CHOICES = {"method": lambda: shadow_methods.METHODS,
                   "clumping": lambda: shadow_methods.CLUMPINGS,
                   "grid": lambda: ("auto", "on", "off")}
MAX_INT_EDIT = 1 << 16           # drag limits of whole-number and real settings
MAX_FLOAT_EDIT = 1e6
MIN_RENDER_SCALE = 0.25


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

    @staticmethod
    def of(frame: Frame, clock: str, fps: float | None,
           maps_per_fragment: float | None = None) -> Figures:
        mpf = frame.maps_per_fragment
        return Figures(ms={k: v for k, v in frame.ms.items() if k not in HIDDEN_PASSES},
                       clock=clock, maps_rendered=frame.maps_rendered,
                       maps_cached=frame.maps_cached,
                       triangles_to_maps=frame.triangles_to_maps,
                       maps_per_fragment=mpf if mpf is not None else maps_per_fragment, fps=fps)


@dataclass
class Changes:
    """What the user changed in the overlay this frame (None: unchanged)."""

    settings: shadow_methods.ShadowSettings | None = None   # needs new maps
    light: object | None = None
    debug_view: str | None = None
    paused: bool | None = None
    render_scale: float | None = None
    soft: bool | None = None

    def apply(self, renderer: Renderer) -> None:
        if self.settings is not None:
            renderer.set_settings(self.settings)
        if self.light is not None:
            renderer.set_light(self.light)
        if self.debug_view is not None:
            renderer.debug_view = self.debug_view
        if self.soft is not None:
            renderer.set_soft(self.soft)


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

    def __init__(self, window=None):
        """``window``: a glfw window whose context is current, or None to draw headless."""
        self.window = window
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
        self._pending: dict[str, float] = {}   # drags in progress on re-planning fields

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
             dt: float | None = None, render_scale: float | None = None) -> Changes:
        """Build this frame's panel; ``size`` is the framebuffer's, ``dt`` the frame time.

        ``render_scale`` (the window's scene-to-window pixel ratio) adds a slider for it.

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
        imgui.set_next_window_size(imgui.ImVec2(PANEL_WIDTH, 0), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_bg_alpha(0.8)
        imgui.begin("shadows")
        imgui.push_item_width(LABELLED_ITEM_WIDTH)
        self._draw_figures(figures)
        self._draw_graph()
        self._draw_controls(renderer, paused, changes)
        if render_scale is not None:
            changed, scale = imgui.slider_float("render scale", render_scale, MIN_RENDER_SCALE,
                                                1.0, "%.2f")
            if changed:
                changes.render_scale = scale
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
        imgui.text(f"triangles into maps {f.triangles_to_maps}")
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
    def _draw_controls(self, renderer: Renderer, paused: bool, changes: Changes) -> None:
        changed, value = imgui.checkbox("pause characters (P)", paused)
        if changed:
            changes.paused = value
        views = list(DEBUG_VIEWS)
        changed, index = imgui.combo("debug view", views.index(renderer.debug_view), views)
        if changed:
            changes.debug_view = views[index]
        if hasattr(renderer, "set_soft"):  # the soft-shadow trace, where the renderer has one
            changed, value = imgui.checkbox("soft shadows", bool(renderer.soft))
            if changed:
                changes.soft = value
        self._draw_sun(renderer, changes)
        if imgui.collapsing_header("hard-shadow settings"):
            self._draw_settings(renderer.settings, changes)
        for note in renderer.method.notes[-2:]:
            imgui.text_wrapped(f"note: {note}")

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

    def _draw_settings(self, settings: shadow_methods.ShadowSettings, changes: Changes) -> None:
        """One control per settings field, chosen by the field's name and default's type."""
        new = {}
        for field in dataclasses.fields(settings):
            name, value = field.name, getattr(settings, field.name)
            label = name.replace("_", " ")
            if name in SETTING_CHOICES:
                items = list(SETTING_CHOICES[name]())
                if value not in items:
                    items.append(value)
                changed, index = imgui.combo(label, items.index(value), items)
                if changed:
                    new[name] = items[index]
            elif name.endswith("_resolution"):
                items = [str(r) for r in RESOLUTIONS]
                if str(value) not in items:
                    items.append(str(value))
                changed, index = imgui.combo(label, items.index(str(value)), items)
                if changed:
                    new[name] = int(items[index])
            elif isinstance(field.default, bool) or isinstance(value, bool):
                changed, flag = imgui.checkbox(label, value)
                if changed:
                    new[name] = flag
            elif value is None or isinstance(value, int):
                self._edit_number(label, name, value, field.default is None, new)
            elif isinstance(value, float):
                self._edit_number(label, name, value, False, new)
            else:
                imgui.text(f"{label}: {value}")
        shading = {k: v for k, v in new.items() if k in SHADING_ONLY}
        for key, value in shading.items():
            setattr(settings, key, value)  # read by the shading pass every frame
        planned = {k: v for k, v in new.items() if k not in SHADING_ONLY}
        if planned:
            changes.settings = dataclasses.replace(settings, **planned)

    def _edit_number(self, label: str, name: str, value, optional: bool, new: dict) -> None:
        """A drag for a number; fields that need new maps apply when the drag ends."""
        if optional:
            changed, auto = imgui.checkbox(f"auto##{name}", value is None)
            imgui.same_line()
            if changed:
                new[name] = None if auto else 1
                return
            if auto:
                imgui.text(label)
                return
        shown = self._pending.get(name, value)
        if isinstance(value, int):
            changed, number = imgui.drag_int(label, int(shown), 0.2, 1, MAX_INT_EDIT)
        else:
            changed, number = imgui.drag_float(label, float(shown), 0.05, 0.0, MAX_FLOAT_EDIT,
                                               "%.2f")
        if changed and name in SHADING_ONLY:
            new[name] = number
        elif changed:
            self._pending[name] = number
        if imgui.is_item_deactivated() and name in self._pending:
            new[name] = self._pending.pop(name)

    def release(self) -> None:
        """Free the backends' GL objects and the imgui and implot contexts."""
        if self.context is None:
            return
        imgui.set_current_context(self.context)
        imgui.backends.opengl3_shutdown()
        if self.window is not None:
            imgui.backends.glfw_shutdown()
        implot.destroy_context(self.plot_context)
        imgui.destroy_context(self.context)
        self.context = None


def draw_over_frame(overlay: Overlay, renderer: Renderer, frame: Frame, dt: float) -> np.ndarray:
    """Headless: draw the panel over the frame in the renderer's target and read it back.

    The frame rate shown is ``1000 / total`` ms, the rate this frame's work alone would allow.
    """
    total = frame.ms.get("total")
    figures = Figures.of(frame, renderer.timer.clock, 1e3 / total if total else None)
    figures.fps_from_total = True
    overlay.draw(figures, renderer, False, renderer.size, dt)
    renderer.target.use()
    overlay.render()
    w, h = renderer.size
    data = renderer.target.read(viewport=(0, 0, w, h), components=3, attachment=0)
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()
