"""The walkaround's input: glfw's key, mouse and focus callbacks, turned into the camera's
moves and the window's commands (game/app/window/camera_control.py names them).

:class:`WindowInput` is a mixin of :class:`~game.app.window.walkaround.Walkaround`, which holds
what it reads and sets: the window, the camera controller, the renderer, the overlay (which
takes keys and clicks while it has focus), and the window's flags.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import imgui_bundle  # noqa: F401 - before glfw, so pyGLFW loads the GLFW 3.5 bundled with it

# isort: split
import glfw

from game.app.window import light_editor
from game.app.window.camera_control import FAST_FACTOR, LIGHT_KEYS, REPEATING_KEYS
from game.app.window.glfw_setup import KEY_NAMES
from game.shadows import registry

if TYPE_CHECKING:
    from game.app.window.camera_control import CameraController
    from game.app.window.overlay import Overlay
    from game.render.renderer import Renderer


class WindowInput:
    """Keys, mouse buttons, cursor moves and focus, as the walkaround answers them."""

    window: object
    controller: CameraController
    renderer: Renderer
    overlay: Overlay | None
    quit: bool
    paused: bool
    selected_light: int
    _screenshot_next: bool

    def on_key(self, window, key, scancode, action, mods) -> None:
        name = KEY_NAMES.get(key, "")
        if action == glfw.REPEAT and name not in REPEATING_KEYS:
            return
        self.key(name, action != glfw.RELEASE)  # a held light key nudges again on each repeat

    def key(self, name: str, pressed: bool) -> None:
        """A key by name (camera_control's names) went down or up."""
        if pressed and self.overlay is not None and self.overlay.wants_keyboard:
            return
        command = self.controller.key(name, pressed)
        if command == "quit":
            self.quit = True
        elif command == "pause":
            self.paused = not self.paused
        elif command == "screenshot":
            self._screenshot_next = True
        elif command == "next_method":
            self.next_method()
        elif command == "toggle_panel" and self.overlay is not None:
            self.overlay.toggle_panel()
        elif command == "capture_cursor":
            mode = glfw.CURSOR_DISABLED if self.controller.captured else glfw.CURSOR_NORMAL
            glfw.set_input_mode(self.window, glfw.CURSOR, mode)
        elif command in LIGHT_KEYS.values():
            self.light_key(command)

    def light_key(self, command: str) -> None:
        """A light key: select the previous or next light, switch the selected one off or on,
        or nudge it (Shift: :data:`FAST_FACTOR` times as far); the renderer plans and draws
        that light's maps anew only when it moved."""
        lights, k = self.renderer.scene.lights, self.selected_light
        if command in ("light_previous", "light_next"):
            self.selected_light = (k + (1 if command == "light_next" else -1)) % len(lights)
        elif command == "light_switch":
            self.renderer.lights_on[k] = not self.renderer.lights_on[k]
        else:
            step = FAST_FACTOR if "shift" in self.controller.held else 1.0
            light = light_editor.nudged(lights[k], command, self.controller.camera.yaw, step)
            if light is not None:
                self.renderer.set_light(light, k)

    def _on_mouse_button(self, window, button, action, mods) -> None:
        if button != glfw.MOUSE_BUTTON_RIGHT:
            return
        if action == glfw.PRESS and self.overlay is not None and self.overlay.wants_mouse:
            return
        self.controller.mouse_button(action == glfw.PRESS)

    def _on_focus(self, window, focused) -> None:
        if not focused:  # keys released elsewhere never reach us
            self.controller.release_all()

    def _on_cursor(self, window, x, y) -> None:
        self.controller.mouse_move(x, y)

    def next_method(self) -> None:
        methods = list(registry.METHODS)
        current = self.renderer.settings.method
        following = methods[(methods.index(current) + 1) % len(methods)] \
            if current in methods else methods[0]
        self.renderer.set_settings(dataclasses.replace(self.renderer.settings,
                                                       method=following))
