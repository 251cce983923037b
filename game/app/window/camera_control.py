"""The walkaround's free-fly camera: keys and mouse in, a view out. No GL and no glfw here.

The window (game/app/window/walkaround.py) turns glfw events into the key names below and calls
:meth:`CameraController.key`, :meth:`CameraController.mouse_move` and
:meth:`CameraController.update`; tests drive the same methods directly.

Controls: W/S forward and back, A/D left and right, Q/E down and up (world Y), Shift moves
faster; mouse look while the right button is held or while the cursor is captured (Tab toggles);
R resets to the scene's camera. Keys that are commands rather than motion (Esc quits, F12 saves a
screenshot, P pauses the characters, M cycles the shadow method, F1 switches the overlay between
its HUD and its full panel, and the light keys: the arrows and Page Up / Page Down move the
selected light, [ and ] select the previous and next light, L switches it off and on) come back
from :meth:`key` as command names for the window to act on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from game import transforms
from game.scene import Camera

MOVE_SPEED_M_S = 4.0          # walking speed
FAST_FACTOR = 4.0             # Shift multiplies the speed by this
LOOK_DEG_PER_PIXEL = 0.15     # mouse-look sensitivity
MAX_PITCH_DEG = 89.0          # never look straight up or down: lookAt would be singular

MOTION_KEYS = {  # key name -> (right, up, forward) direction in camera terms
    "w": (0, 0, 1), "s": (0, 0, -1), "a": (-1, 0, 0), "d": (1, 0, 0),
    "q": (0, -1, 0), "e": (0, 1, 0),
}
# The light keys (game/app/window/light_editor.py moves the light); held, they repeat.
LIGHT_KEYS = {"left": "light_left", "right": "light_right", "up": "light_forward",
              "down": "light_back", "page_up": "light_up", "page_down": "light_down",
              "[": "light_previous", "]": "light_next", "l": "light_switch"}
REPEATING_KEYS = ("left", "right", "up", "down", "page_up", "page_down")
COMMAND_KEYS = {"escape": "quit", "f12": "screenshot", "p": "pause", "r": "reset",
                "tab": "capture_cursor", "m": "next_method", "f1": "toggle_panel",
                **LIGHT_KEYS}


@dataclass
class FlyCamera:
    """Position plus yaw and pitch (degrees); yaw 0 looks down -Z, positive yaw turns right."""

    position: np.ndarray
    yaw: float
    pitch: float
    fov: float
    near: float
    far: float

    @staticmethod
    def from_camera(camera: Camera) -> FlyCamera:
        d = np.asarray(camera.target, float) - np.asarray(camera.position, float)
        d = d / np.linalg.norm(d)
        yaw = math.degrees(math.atan2(d[0], -d[2]))
        pitch = math.degrees(math.asin(float(np.clip(d[1], -1.0, 1.0))))
        pitch = float(np.clip(pitch, -MAX_PITCH_DEG, MAX_PITCH_DEG))
        return FlyCamera(np.array(camera.position, float), yaw, pitch, camera.fov, camera.near,
                         camera.far)

    def forward(self) -> np.ndarray:
        y, p = math.radians(self.yaw), math.radians(self.pitch)
        return np.array([math.sin(y) * math.cos(p), math.sin(p), -math.cos(y) * math.cos(p)])

    def right(self) -> np.ndarray:
        y = math.radians(self.yaw)
        return np.array([math.cos(y), 0.0, math.sin(y)])

    def view_matrix(self) -> np.ndarray:
        return transforms.look_at(self.position, self.position + self.forward())

    def proj_matrix(self, size: tuple[int, int]) -> np.ndarray:
        return transforms.perspective(self.fov, size[0] / max(1, size[1]), self.near, self.far)


class CameraController:
    """Held keys and mouse motion to camera motion; until the user moves, the scene's own view.

    Until the first move or turn, :meth:`view_matrix` is the scene camera's exact lookAt, so a
    window frame matches a headless capture of the same scene bit for bit.
    """

    def __init__(self, camera: Camera):
        self.home = camera
        self.held: set[str] = set()
        self.looking = False       # right button held
        self.captured = False      # cursor captured (Tab)
        self._last_mouse: tuple[float, float] | None = None
        self.reset()

    def reset(self) -> None:
        self.camera = FlyCamera.from_camera(self.home)
        self.moved = False

    def key(self, name: str, pressed: bool) -> str | None:
        """A key went down or up; returns a command name for keys that are commands."""
        if name in ("shift", *MOTION_KEYS):
            (self.held.add if pressed else self.held.discard)(name)
            return None
        if not pressed or name not in COMMAND_KEYS:
            return None
        command = COMMAND_KEYS[name]
        if command == "reset":
            self.reset()
        elif command == "capture_cursor":
            self.captured = not self.captured
            self._last_mouse = None
        return command

    def release_all(self) -> None:
        """Forget held keys (the window lost focus or the overlay took the keyboard)."""
        self.held.clear()
        self.looking = False

    def mouse_button(self, right_pressed: bool) -> None:
        self.looking = right_pressed
        self._last_mouse = None

    def mouse_move(self, x: float, y: float) -> None:
        """The cursor moved to (x, y) window pixels; turns the camera while looking."""
        last, self._last_mouse = self._last_mouse, (x, y)
        if last is None or not (self.looking or self.captured):
            return
        dx, dy = x - last[0], y - last[1]
        if dx == 0 and dy == 0:
            return
        c = self.camera
        c.yaw = (c.yaw + dx * LOOK_DEG_PER_PIXEL + 180.0) % 360.0 - 180.0
        c.pitch = float(np.clip(c.pitch - dy * LOOK_DEG_PER_PIXEL, -MAX_PITCH_DEG,
                                MAX_PITCH_DEG))
        self.moved = True

    def update(self, dt: float) -> None:
        """Move by the held keys over ``dt`` seconds."""
        step = np.zeros(3)
        for name in self.held & MOTION_KEYS.keys():
            step += MOTION_KEYS[name]
        if not step.any() or dt <= 0:
            return
        c = self.camera
        speed = MOVE_SPEED_M_S * (FAST_FACTOR if "shift" in self.held else 1.0)
        world = step[0] * c.right() + step[1] * np.array([0.0, 1.0, 0.0]) + step[2] * c.forward()
        c.position = c.position + world / np.linalg.norm(world) * speed * dt
        self.moved = True

    def view_matrix(self) -> np.ndarray:
        if not self.moved:
            return transforms.look_at(self.home.position, self.home.target)
        return self.camera.view_matrix()
