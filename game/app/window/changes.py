"""What the user changed in the overlay in one frame, and :meth:`Changes.apply`, the one place a
change reaches the renderer and the window.

The overlay's pieces (the view, shadows and lights tabs) only fill in a :class:`Changes`; nothing
changes until it is applied, after the overlay's frame is built, so that a frame's controls all
read the same state.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from game.scene.model import Light
from game.shadows.plan import ShadowSettings

if TYPE_CHECKING:
    from game.render.renderer import Renderer


class WindowControls(Protocol):
    """What a window keeps of the state the overlay edits (the walkaround)."""

    paused: bool
    render_scale: float
    selected_light: int   # the light that the lights tab and the light keys move

    def set_soft(self, on: bool) -> None: ...

    def set_soft_trace(self, divisor: int | None = None, samples: int | None = None,
                       method: str | None = None) -> None: ...


@dataclass
class Changes:
    """What the user changed in the overlay this frame (None: unchanged)."""

    settings: ShadowSettings | None = None   # needs new maps
    # Lights moved, by index: only their maps are planned and drawn anew.
    lights: dict[int, Light] = dataclasses.field(default_factory=dict)
    lights_on: dict[int, bool] = dataclasses.field(default_factory=dict)  # switched, by index
    debug_view: str | None = None
    # The window's own state (WindowControls).
    paused: bool | None = None
    render_scale: float | None = None
    soft: bool | None = None          # soft shadows traced, from the next frame
    soft_divisor: int | None = None   # the window's soft trace: one pixel in N x N ...
    soft_samples: int | None = None   # ... with this many samples (or maps)
    soft_method: str | None = None    # ... by this soft method
    selected_light: int | None = None

    def apply(self, renderer: Renderer, window: WindowControls | None = None) -> None:
        """Every change: the window's first (none where ``window`` is None: a headless
        overlay has no window state), then the renderer's.

        Raises what the renderer raises for settings or a light it refuses
        (``GameError``, ``ValueError``); the window's changes are kept then.
        """
        if window is not None:
            if self.paused is not None:
                window.paused = self.paused
            if self.render_scale is not None:
                window.render_scale = self.render_scale
            if self.soft is not None:
                window.set_soft(self.soft)
            if (self.soft_divisor, self.soft_samples, self.soft_method) != (None,) * 3:
                window.set_soft_trace(self.soft_divisor, self.soft_samples, self.soft_method)
            if self.selected_light is not None:
                window.selected_light = self.selected_light
        if self.settings is not None:
            renderer.set_settings(self.settings)
        for index, light in self.lights.items():
            renderer.set_light(light, index)
        for index, on in self.lights_on.items():
            renderer.lights_on[index] = on
        if self.debug_view is not None:
            renderer.debug_view = self.debug_view
