"""The timing overlay: imgui + implot through imgui-bundle's own GLFW and OpenGL3 backends.

It has two modes: the HUD (the window's default; game/app/window/hud.py), a small corner box of
the frame rate, the frame's milliseconds and a bar of the passes; and the panel (F1 in the window,
always in ``capture --overlay``; game/app/window/panel.py), the figures of every pass, a rolling
graph of them and a tab per kind of control: the view, the hard-shadow settings (the method among
them, ``traced`` included), the lights and the maps. Beside either, a strip along the bottom
says where a light's shadows collapsed. What the user changes comes back from
:meth:`Overlay.draw` as a :class:`~game.app.window.changes.Changes`, for its caller to apply.

The same overlay draws into a window (``window`` given: the GLFW backend feeds it input) or into
any framebuffer with no window at all (``capture --overlay``: display size and frame time are set
by hand). The controls are built from :class:`ShadowSettings`'s fields and the method list, so
settings and methods added later appear without edits here.

The overlay owns an imgui and an implot context and the OpenGL3 backend's GL objects (made in
the context current at construction); :meth:`Overlay.release` frees them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import imgui_bundle  # noqa: F401 - before glfw, so pyGLFW loads the GLFW 3.5 bundled with it
import numpy as np
from imgui_bundle import imgui, implot

from game.app.window.changes import Changes
from game.app.window.figures import Figures, PassHistory
from game.app.window.hud import BarSegment, Hud
from game.app.window.imgui_layout import font_scale
from game.app.window.light_editor import LightEditor
from game.app.window.panel import TABS, Panel, PanelLayout, WindowState
from game.render.passes import TOTAL

if TYPE_CHECKING:
    from game.render.frame import Frame
    from game.render.renderer import Renderer

GLSL_VERSION = "#version 430"
COLLAPSE_REFRESH_S = 0.5  # the collapse strip's notes are made anew at most this often


class Overlay:
    """The HUD or the panel, drawn into whatever framebuffer is bound when :meth:`render` runs."""

    def __init__(self, window=None, open_tab: str = TABS[0], panel: bool = True):
        """``window``: a glfw window whose context is current, or None to draw headless.

        ``open_tab`` is the tab of controls shown first (one of :data:`TABS`); ``panel``
        whether the full panel is shown first rather than the HUD (:meth:`toggle_panel`).
        """
        self.history = PassHistory()
        self.full_panel = Panel(self.history, open_tab)   # raises for an unknown tab
        self.hud = Hud(self.history)
        self.window = window
        self.panel = panel
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
        self.rect = (0, 0, 0, 0)   # x, y, w, h of the HUD or panel last drawn, window pixels
        self.message = ""   # the last change the renderer refused, shown in the panel

    # What the HUD and the panel drew last, and their editors' state (tests read them).
    @property
    def open_tab(self) -> str:
        return self.full_panel.open_tab

    @property
    def lights(self) -> LightEditor:
        return self.full_panel.lights

    @property
    def layout(self) -> PanelLayout | None:
        return self.full_panel.layout

    @property
    def hud_lines(self) -> tuple[str, ...]:
        return self.hud.lines

    @property
    def bar(self) -> list[BarSegment]:
        return self.hud.bar

    @property
    def warnings(self) -> tuple[str, ...]:
        """The collapse notes the strip along the bottom showed last."""
        return self.hud.warnings

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
        self.history.record(figures.ms)
        changes = Changes()
        windowed = self.window is not None
        if self.panel:
            state = WindowState(paused, render_scale, soft, selected_light)
            title = "shadows  (F1: HUD)" if windowed else "shadows"
            self.rect = self.full_panel.draw(figures, renderer, size, state, changes,
                                             self.message, title)
        else:
            self.rect = self.hud.draw(figures, renderer, size, soft, hint=windowed)
        self.hud.draw_warnings(renderer.collapse_notes(COLLAPSE_REFRESH_S), size,
                               self.rect[0] + self.rect[2] if self.panel else 0)
        imgui.render()
        return changes

    def render(self) -> None:
        """Draw the HUD or panel built by :meth:`draw` into the bound framebuffer."""
        imgui.set_current_context(self.context)
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())

    def draw_over_frame(self, renderer: Renderer, frame: Frame, dt: float) -> np.ndarray:
        """Headless: draw the panel (or the HUD) over the frame's picture
        (``renderer.display``) and read it back.

        The frame rate shown is ``1000 / total`` ms, the rate this frame's work alone would allow.
        """
        total = frame.ms.get(TOTAL)
        figures = Figures.of(frame, renderer.timer.clock, 1e3 / total if total else None)
        figures.fps_from_total = True
        first = self.history.frames_seen == 0
        self.draw(figures, renderer, False, renderer.size, dt)
        if first:
            # imgui measures an auto-resized window in its first frame and shows it from the
            # second: build the first frame twice, so that frame 0 of a capture has its panel.
            self.history.clear()
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
        self.full_panel.release()
        imgui.backends.opengl3_shutdown()
        if self.window is not None:
            imgui.backends.glfw_shutdown()
        implot.destroy_context(self.plot_context)
        imgui.destroy_context(self.context)
        self.context = None
