"""The panel's view tab: pausing the characters, the debug view, soft shadows and their trace,
the sun, and the render scale."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np
from imgui_bundle import imgui

from game.app.window import soft_controls
from game.app.window.changes import Changes
from game.app.window.figures import SoftFigures
from game.app.window.light_editor import sun_angles, sun_direction
from game.gpu.blocks import DEBUG_VIEWS
from game.soft.methods import METHODS

if TYPE_CHECKING:
    from game.render.renderer import Renderer

# The labels beside the controls (their widths set the controls').
LABELS = ("debug view", "sun azimuth", "sun elevation", "render scale", "soft method",
          "trace divisor", "samples")
# The soft trace's controls: the method, one traced pixel per N x N (1: every pixel), and
# samples per point or maps along the segment (soft_controls.COUNT_RANGE).
SOFT_DIVISOR_RANGE = (1, 8)
MIN_RENDER_SCALE = 0.25


class ViewTab:
    """Draws the view tab; the changes go into the overlay's :class:`Changes`."""

    def __init__(self) -> None:
        # The sun sliders' angles and the direction they were taken from (or made).
        self._sun: tuple[np.ndarray, tuple[float, float]] | None = None

    def draw(self, renderer: Renderer, paused: bool, render_scale: float | None,
             soft: bool | None, changes: Changes, trace: SoftFigures | None) -> None:
        """``render_scale`` None: no slider for it; ``soft`` None: no soft-shadow controls."""
        changed, value = imgui.checkbox("pause characters (P)", paused)
        if changed:
            changes.paused = value
        views = list(DEBUG_VIEWS)
        changed, index = imgui.combo("debug view", views.index(renderer.debug_view), views)
        if changed:
            changes.debug_view = views[index]
        if soft and renderer.debug_view != "none":
            imgui.text_disabled("soft shadows wait while a debug view shows the hard maps")
        if soft is not None and renderer.scene.linear_light is None:
            imgui.text_disabled("soft shadows: the scene has no [linear_light]")
        elif soft is not None:
            self._draw_soft(soft, changes, trace, renderer.traced.last_soft)
        self._draw_sun(renderer, changes)
        if render_scale is not None:
            changed, scale = imgui.slider_float("render scale", render_scale, MIN_RENDER_SCALE,
                                                1.0, "%.2f")
            if changed:
                changes.render_scale = scale

    @staticmethod
    def _draw_soft(soft: bool, changes: Changes, trace: SoftFigures | None,
                   settings) -> None:
        """The soft-shadow switch and, while on, the method, the trace's divisor and its
        samples (or maps) where the method has them."""
        changed, value = imgui.checkbox("soft shadows (linear light)", soft)
        if changed:
            changes.soft = value
        if not soft or trace is None or settings is None:
            return
        methods = list(METHODS)
        changed, index = imgui.combo("soft method", methods.index(settings.method), methods)
        if changed:
            changes.soft_method = methods[index]
        changed, divisor = imgui.slider_int("trace divisor", trace.divisor,
                                            *SOFT_DIVISOR_RANGE, "1 in %d per side")
        if changed:
            changes.soft_divisor = divisor
        name = soft_controls.count_name(settings.method)
        if name is not None:
            changed, count = imgui.slider_int(name, trace.samples,
                                              *soft_controls.COUNT_RANGE[name])
            if changed:
                changes.soft_samples = count

    def _draw_sun(self, renderer: Renderer, changes: Changes) -> None:
        light = renderer.scene.light
        if not light.parallel:
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
