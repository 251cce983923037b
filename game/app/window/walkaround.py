"""The walkaround window (``python -m game play``): glfw, the renderer's frame, the overlay.

Each frame: poll input -> move the camera (game/app/window/camera_control.py) -> render the scene
into the renderer's own target (with the ``traced`` method or soft shadows on, the renderer
traces over the frame's G-buffer and lights it again through the traced visibility) -> draw the
overlay over it -> blit to the window -> swap.

Soft shadows (the scene's ``[linear_light]``, overlay checkbox or ``play --soft``): the linear
light is one more light, added to the scene's lights, which keep the hard method's shadows. The
frame and its G-buffer render at the window's resolution (times the render scale). A raster
soft method (the default, game/app/window/soft_controls.py) is looked up at one pixel in a few
and, where those points disagree, at every pixel, in the composite pass itself
(game/soft/direct.py). A traced method traces one pixel in a few, upsampled by a depth- and
normal-aware filter and composited at full resolution (game/soft/upsample.py); while the view
stays, frames trace the other pixels and every pixel's samples accumulate, and the pixels a
moving walker may shadow start again (game/soft/accumulate.py). The renderer keeps a G-buffer
only while soft shadows or the traced method need it (it costs fill on llvmpipe).

The scene clock runs in real time (or in fixed steps, for scripts) and stops while the
characters are paused. The light keys select, switch and nudge one light of the scene, the one
selected in the overlay's lights tab (game/app/window/light_editor.py); a light that moves has
only its own maps re-rendered. A minimised window, whose framebuffer is zero-sized, renders nothing
and waits.

The GL context is the window's, wrapped once by game/gpu/context.py. It is always an EGL context
(also on X11 and Wayland), because PyOpenGL finds its functions through EGL
(game/gpu/context.py sets PYOPENGL_PLATFORM); GLFW's null platform gives the same window with no
display at all, for tests.
"""

from __future__ import annotations

import dataclasses
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import imgui_bundle  # noqa: F401 - before glfw, so pyGLFW loads the GLFW 3.5 bundled with it

# isort: split
import glfw
import numpy as np

from game.app import interrupts, outputs
from game.app.window import soft_controls
from game.app.window.figures import (
    OVERLAY,
    PRESENT,
    WINDOW_PASSES,
    Figures,
    SoftFigures,
    stats_entry,
)
from game.app.window.glfw_setup import open_window
from game.app.window.overlay import Overlay
from game.app.window.present import Presenter
from game.app.window.window_input import WindowInput
from game.errors import GameError
from game.gpu import context
from game.render.depth_first import DepthFirst
from game.render.frame import Frame
from game.render.passes import DRAWING_PASSES, TOTAL
from game.render.renderer import Renderer, View
from game.scene import Scene
from game.shadows.plan import ShadowSettings

DEFAULT_SIZE = (960, 540)
MPF_EVERY_FRAMES = 30        # read the frame back to count maps per fragment this often
FPS_WINDOW_FRAMES = 60       # frames in the rolling frame-rate average
MINIMISED_WAIT_S = 0.1
SCREENSHOT_DIR = Path("screenshots")

@dataclass
class PlayOptions:
    size: tuple[int, int] = DEFAULT_SIZE
    frames: int | None = None            # quit after this many rendered frames
    screenshot: Path | None = None       # the last frame as shown, overlay included
    stats: Path | None = None
    time_step: float | None = None       # scene seconds per frame; None: real time
    overlay: bool = True
    panel: bool = False                  # open with the overlay's full panel, not its HUD (F1)
    clock: str = "auto"
    debug_view: str = "none"
    render_scale: float = 1.0            # scene pixels per window pixel, per side
    soft: bool = False                   # trace the linear light's soft shadows
    cull: bool = True                    # camera pass: only triangles that can show
    depth_first: DepthFirst = DepthFirst.AUTO  # camera pass: its depth before it shades
    platform: str = "auto"               # "null": no display (tests)
    antialias: bool = True               # FXAA on the picture shown (never on the dumps)
    # The window filters its shadow edges (PCF) unless told otherwise; captures keep theirs.
    settings: ShadowSettings = dataclasses.field(
        default_factory=lambda: ShadowSettings(pcf=True))


class Walkaround(WindowInput):
    """One window, its context, a renderer and an overlay; :meth:`close` releases them all."""

    def __init__(self, scene: Scene, opts: PlayOptions):
        from game.app.window.camera_control import CameraController

        if opts.soft and scene.linear_light is None:
            raise GameError("soft shadows: the scene has no [linear_light]")
        self.scene = scene
        self.opts = opts
        self.soft = opts.soft
        self.soft_settings = soft_controls.window_settings()
        self.upsampling = soft_controls.window_upsampling()
        self.window = open_window(opts.size, opts.platform)
        glfw.make_context_current(self.window)
        # Scripted runs are measured: never wait for the display's refresh.
        glfw.swap_interval(0 if opts.frames else 1)
        try:
            self.ctx = context.wrap_current()
        except GameError:
            glfw.destroy_window(self.window)
            glfw.terminate()
            raise
        self.controller = CameraController(scene.camera)
        try:
            size = self.framebuffer_size() or opts.size
            self.renderer = Renderer(self.ctx, scene, size, opts.settings, clock=opts.clock,
                                     cull=opts.cull, depth_first=opts.depth_first)
        except BaseException:
            self.ctx.release()
            glfw.destroy_window(self.window)
            glfw.terminate()
            raise
        self.renderer.debug_view = opts.debug_view
        self.render_scale = opts.render_scale
        self.presenter = Presenter(self.ctx, opts.antialias)
        # Our callbacks first: the imgui backend chains to the ones installed before it.
        glfw.set_key_callback(self.window, self.on_key)
        glfw.set_mouse_button_callback(self.window, self._on_mouse_button)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)
        glfw.set_window_focus_callback(self.window, self._on_focus)
        # A scene of several lights opens the panel on its lights tab.
        tab = "lights" if len(scene.lights) > 1 else "view"
        self.overlay = (Overlay(self.window, open_tab=tab, panel=opts.panel) if opts.overlay
                        else None)
        self.paused = False
        self.selected_light = 0   # the light that the lights tab and the light keys move
        self.scene_time = 0.0
        self.frames = 0
        self.quit = False
        self._screenshot_next = False
        self.shots = 0
        self.last_figures: Figures | None = None
        self.frame_stats: list[dict] = []
        # Per-frame entries only for runs that end or write them: an open run must not grow.
        self.keep_stats = opts.frames is not None or opts.stats is not None
        self._frame_times: deque[float] = deque(maxlen=FPS_WINDOW_FRAMES)
        self._mpf: float | None = None
        self._candidates: float | None = None  # map records per fragment, when last read
        self._window_ms: dict[str, float] = {}
        self._good_settings: ShadowSettings | None = None

    def set_soft(self, on: bool) -> None:
        """Soft shadows of the linear light on or off, from the next frame."""
        if on and self.scene.linear_light is None:
            raise GameError("soft shadows: the scene has no [linear_light]")
        self.soft = on

    def set_soft_trace(self, divisor: int | None = None, samples: int | None = None,
                       method: str | None = None) -> None:
        """The soft trace from the next frame: one pixel in ``divisor`` x ``divisor``, with
        ``method`` and ``samples`` per point (or maps, for segment-maps; None: as it is)."""
        if divisor is not None:
            self.upsampling = dataclasses.replace(self.upsampling, divisor=divisor)
        self.soft_settings = soft_controls.choose(self.soft_settings, method, samples)

    def _soft_settings(self):
        """The soft trace's settings while soft shadows are on and no debug view shows the hard
        maps instead (the view tab says so): the linear light adds to the scene's lights."""
        return self.soft_settings if self.soft and self.renderer.debug_view == "none" else None

    def gl_objects(self) -> int:
        """Live GL objects of the renderer, its tracer included (toggling must not grow them)."""
        return sum(self.renderer.gl_objects().values())

    # -- frames -------------------------------------------------------------------------------
    def framebuffer_size(self) -> tuple[int, int] | None:
        """The framebuffer's size, or None while it is zero-sized or the window minimised."""
        w, h = glfw.get_framebuffer_size(self.window)
        if w <= 0 or h <= 0 or glfw.get_window_attrib(self.window, glfw.ICONIFIED):
            return None
        return w, h

    def render_size(self, size: tuple[int, int]) -> tuple[int, int]:
        """The scene's render size for a window framebuffer of ``size``."""
        return (max(1, round(size[0] * self.render_scale)),
                max(1, round(size[1] * self.render_scale)))

    def view(self, size: tuple[int, int]) -> View:
        return View(self.controller.view_matrix(), self.controller.camera.proj_matrix(size))

    def step(self, dt: float) -> bool:
        """Poll input and draw one frame; False when nothing was drawn (minimised)."""
        glfw.poll_events()
        if glfw.window_should_close(self.window):
            self.quit = True
        size = self.framebuffer_size()
        if size is None or self.quit:
            return False
        self.controller.update(dt)
        if not self.paused:  # with fixed steps frame k shows k * dt, as capture's frames do
            self.scene_time += dt
        frame = self._render(size)
        figures = self._figures(frame)
        last = self.opts.frames is not None and self.frames + 1 >= self.opts.frames
        shot = self._screenshot_next or (last and self.opts.screenshot is not None)
        screen = self._present(size, shot)
        if self.overlay is not None:
            self._draw_overlay(figures, size)
        timer = self.renderer.timer
        if self.canvas is not screen:
            with timer.measure(PRESENT, wall=True):
                self.ctx.copy_framebuffer(screen, self.canvas)
        self._window_ms = {k: timer.ms[k] for k in WINDOW_PASSES if k in timer.ms}
        figures.ms.update(self._window_ms)
        self.last_figures = figures
        if self.keep_stats:
            self.frame_stats.append(stats_entry(self.frames, self.scene_time, frame, figures,
                                                self.renderer.settings.method, self.soft))
        self.frames += 1
        if shot:
            self._save_screenshot(size, self.opts.screenshot if last else None)
        glfw.swap_buffers(self.window)
        return True

    def _render(self, size: tuple[int, int]) -> Frame:
        """The scene's frame for a window of ``size``, into the renderer's own target.

        Settings the GL cannot take (too many texels) are undone, with the overlay saying why,
        and the frame rendered again with the last settings that rendered.
        """
        self.renderer.set_gbuffer(self.soft)
        self.renderer.resize(self.render_size(size))
        view = self.view(size)
        # The reduced soft trace accumulates while this view (and the characters) stay.
        self.renderer.traced.reduce_soft(self.upsampling if self.soft else None,
                                         view.view.tobytes() + view.proj.tobytes(),
                                         np.linalg.inv(view.view)[:3, 3])
        read = self.frames % MPF_EVERY_FRAMES == 0
        # Counting the map records draws the shading pass once more (outside the frame's
        # timings, not its wall time): only while the panel that shows them is open.
        self.renderer.count_candidates = self.overlay is not None and self.overlay.panel
        try:
            frame = self.renderer.render(self.scene_time, view, read=read,
                                         soft=self._soft_settings())
        except GameError as exc:
            if self._good_settings is None or self.overlay is None:
                raise
            self.renderer.set_settings(self._good_settings)
            self.overlay.message = str(exc)
            self.renderer.set_gbuffer(self.soft)
            frame = self.renderer.render(self.scene_time, view, read=read,
                                         soft=self._soft_settings())
        self._good_settings = self.renderer.settings
        return frame

    def _figures(self, frame: Frame) -> Figures:
        """What the overlay says about ``frame``, with the last frame's window passes."""
        if frame.maps_per_fragment is not None:
            self._mpf = frame.maps_per_fragment
            self._candidates = frame.map_candidates_per_fragment
        fps = (len(self._frame_times) / sum(self._frame_times)
               if self._frame_times and sum(self._frame_times) > 0 else None)
        figures = Figures.of(frame, self.renderer.timer.clock, fps, self._mpf, self._candidates)
        figures.soft = SoftFigures.of(frame, self.renderer.traced.reduced_state,
                                      self.soft_settings)
        figures.ms.update(self._window_ms)
        return figures

    def _present(self, size: tuple[int, int], shot: bool):
        """Show the scene's frame in a canvas, which the overlay then draws over; returns the
        window's framebuffer (:attr:`canvas` is it, or the presenter's target).

        The route is the one that was cheapest on llvmpipe: a full-size frame without FXAA is
        copied into the presenter's colour-only canvas and later blitted to the window (a blit
        straight from a target with a depth attachment, or a textured draw, cost more); a frame
        that is drawn anyway (scaled, or anti-aliased) is drawn straight into the window. A frame
        saved as a screenshot (``shot``) always goes through the readable canvas, so the file
        holds what the window shows.
        """
        screen = self.ctx.detect_framebuffer(0)
        with self.renderer.timer.measure(PRESENT, wall=True):
            framebuffer, texture = self.renderer.display
            if shot or (self.renderer.size == size and not self.presenter.antialias):
                self.presenter.resize(size)
                self.presenter.show(framebuffer, texture)
                self.canvas = self.presenter.target
            else:
                self.presenter.draw(texture, screen, size)
                self.canvas = screen
        return screen

    def _draw_overlay(self, figures: Figures, size: tuple[int, int]) -> None:
        """The overlay over the canvas, then what the user changed in it applied; a change
        the renderer refuses is undone, with the overlay saying why."""
        with self.renderer.timer.measure(OVERLAY, wall=True):
            changes = self.overlay.draw(figures, self.renderer, self.paused, size,
                                        render_scale=self.render_scale, soft=self.soft,
                                        selected_light=self.selected_light)
            self.canvas.use()
            self.overlay.render()
        try:
            changes.apply(self.renderer, self)
        except (GameError, ValueError) as exc:
            if self._good_settings is not None:
                self.renderer.set_settings(self._good_settings)
            self.overlay.message = str(exc)

    def read_screen(self, size: tuple[int, int]) -> np.ndarray:
        """What the window shows now, (H, W, 3) uint8 with row 0 at the top."""
        data = self.canvas.read(viewport=(0, 0, *size), components=3, attachment=0)
        return np.frombuffer(data, np.uint8).reshape(size[1], size[0], 3)[::-1].copy()

    def _save_screenshot(self, size: tuple[int, int], path: Path | None) -> None:
        self._screenshot_next = False
        if path is None:
            SCREENSHOT_DIR.mkdir(exist_ok=True)
            while True:
                path = SCREENSHOT_DIR / f"screenshot_{self.shots:04d}.png"
                self.shots += 1
                if not path.exists():
                    break
        self.screenshot = self.read_screen(size)
        outputs.write_png(path, self.screenshot)

    def run(self, script: Callable[[Walkaround], None] | None = None) -> dict:
        """Run until Esc, the window closes, Ctrl-C, or ``opts.frames`` frames; returns the
        stats (``interrupted``: whether Ctrl-C ended it).

        ``script``, when given, is called before every frame (tests drive input with it).
        """
        start = last = last_start = time.perf_counter()
        first_frame_end = None
        with interrupts.caught() as interrupted:  # Ctrl-C: stop, keep the stats so far
            while not self.quit:
                interrupts.check()
                if self.opts.frames is not None and self.frames >= self.opts.frames:
                    break
                if script is not None:
                    script(self)
                # The scene advances by the real time between frame starts (or fixed steps); the
                # first frame shows the start time.
                now = time.perf_counter()
                if self.frames == 0:
                    dt = 0.0
                elif self.opts.time_step is not None:
                    dt = self.opts.time_step
                else:
                    dt = now - last_start
                last_start = now
                if not self.step(dt):
                    if not self.quit:
                        glfw.wait_events_timeout(MINIMISED_WAIT_S)
                    last = last_start = time.perf_counter()  # no jump for the time minimised
                    continue
                end = time.perf_counter()
                self._frame_times.append(end - last)
                if self.keep_stats:
                    self.frame_stats[-1]["frame_ms"] = round((end - last) * 1e3, 4)
                if first_frame_end is None:
                    first_frame_end = end
                last = end
        elapsed = last - (first_frame_end or start)
        timed = max(0, self.frames - 1)  # the first frame compiles and renders every map
        return {**context.describe(self.ctx), "clock": self.renderer.timer.clock,
                "scene": self.scene.given,
                "size": list(glfw.get_framebuffer_size(self.window)),
                "render_size": list(self.renderer.size), "method": self.renderer.settings.method,
                "soft": self.soft,
                "overlay": self.overlay is not None,
                # x, y, w, h in window pixels from the top-left: where the panel was drawn last
                "overlay_rect": list(self.overlay.rect) if self.overlay is not None else None,
                "fps": round(timed / elapsed, 3) if timed and elapsed > 0 else None,
                "interrupted": interrupted.happened, "notes": self.renderer.notes,
                "frames": self.frame_stats}

    def close(self) -> None:
        """Release the overlay, the renderer, the context and the window, in that order."""
        if self.window is None:
            return
        glfw.make_context_current(self.window)
        if self.overlay is not None:
            self.overlay.release()
            self.overlay = None
        self.presenter.release()
        self.renderer.release()
        self.ctx.release()
        glfw.destroy_window(self.window)
        self.window = None
        glfw.terminate()


def play(scene: Scene, opts: PlayOptions) -> dict:
    """Open the walkaround, run it, write the stats file if asked; returns the stats."""
    app = Walkaround(scene, opts)
    try:
        stats = app.run()
    finally:
        app.close()
    if opts.stats is not None:
        outputs.write_json(opts.stats, stats)
    if stats["interrupted"]:
        raise interrupts.Interrupted
    return stats


def summary(stats: dict) -> str:
    """One line: the frame rate and median ms per pass over the frames after the first."""
    frames = stats["frames"][1:] or stats["frames"]
    names = [n for n in (*DRAWING_PASSES, TOTAL, *WINDOW_PASSES)
             if any(n in f["ms"] for f in frames)]
    med = {n: float(np.median([f["ms"].get(n, 0.0) for f in frames])) for n in names}
    fps = f"{stats['fps']:.1f} fps" if stats["fps"] else "fps -"
    return (f"{fps}, median ms: " + ", ".join(f"{k} {v:.2f}" for k, v in med.items())
            + f" ({stats['clock']} on {stats['renderer']}, window {stats['size'][0]}x"
            f"{stats['size'][1]}, scene {stats['render_size'][0]}x{stats['render_size'][1]})")
