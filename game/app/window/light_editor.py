"""The overlay's lights tab and the keys that move a light.

The tab lists every hard-shadow light of the scene: its index and kind, a switch
(``Renderer.lights_on``), its maps this frame and how many of them were re-rendered. One light
is selected; drags move its position (spot and point) or turn its direction (directional and
spot). The arrow keys and Page Up / Page Down nudge the same light (:func:`nudged`).

Drags and keys make the new light through :func:`moved`, which gives None when the value did
not change or cannot be a light's (a zero direction), so that the renderer plans and draws the
light's maps anew (``Renderer.set_light``) only for a real move.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from imgui_bundle import imgui

from game.app.window.changes import Changes
from game.scene.model import Light
from game.shadows.lights import LightSpan
from game.shadows.plan import ShadowPlan

if TYPE_CHECKING:
    from game.render.renderer import Renderer

# What a drag moves, per kind of light.
MOVED_FIELDS = {"directional": ("direction",), "spot": ("position", "direction"),
                "point": ("position",)}
POSITION_DRAG_M = 0.05          # metres per pixel dragged
DIRECTION_DRAG = 0.005          # change of a direction component per pixel dragged
NUDGE_M = 0.5                   # metres per press of an arrow key (times FAST_FACTOR with Shift)
NUDGE_DEG = 5.0                 # degrees a directional light turns per press
MAX_NUDGE_ELEVATION_DEG = 89.0  # the keys never turn a light straight up or down
LIST_ROWS = 10                  # rows of the light list shown before it scrolls
# The light keys: camera_control.COMMAND_KEYS turns them into these commands.
NUDGES = {  # command -> (right, up, away from the camera) in metres, before the step
    "light_left": (-1, 0, 0), "light_right": (1, 0, 0), "light_down": (0, -1, 0),
    "light_up": (0, 1, 0), "light_back": (0, 0, -1), "light_forward": (0, 0, 1),
}
KEYS_HINT = "keys: arrows, Page Up / Down move it; [ ] select; L switches it"
LABELS = ("position", "direction")   # the labels beside the drags (their widths set the drags')


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


def moved(light: Light, field: str, value) -> Light | None:
    """``light`` with its ``position`` or ``direction`` set to ``value`` (a direction is
    normalised); None when that is the light already, or not a usable value."""
    if field not in MOVED_FIELDS[light.kind]:
        raise ValueError(f"a {light.kind} light has no {field} to move")
    new = np.asarray(value, float)
    if new.shape != (3,) or not np.isfinite(new).all():
        return None
    if field == "direction":
        length = float(np.linalg.norm(new))
        if length < 1e-6:
            return None
        new = new / length
    if np.array_equal(new, getattr(light, field)):
        return None
    return dataclasses.replace(light, **{field: new})


def nudged(light: Light, command: str, yaw: float, step: float = 1.0) -> Light | None:
    """``light`` moved by one press of a light key (a command of :data:`NUDGES`).

    Spot and point lights move :data:`NUDGE_M` times ``step`` metres: left and right along the
    camera's right, forward and back along where it looks (level), up and down in world Y. A
    directional light turns instead: left and right by azimuth, forward and back by elevation,
    :data:`NUDGE_DEG` times ``step`` degrees; up and down leave it. ``yaw`` is the camera's yaw
    (degrees, 0 looking down -Z).
    """
    right, up, away = NUDGES[command]
    if light.parallel:
        if right == 0 and away == 0:
            return None
        azimuth, elevation = sun_angles(light.direction)
        elevation = float(np.clip(elevation + away * NUDGE_DEG * step,
                                  -MAX_NUDGE_ELEVATION_DEG, MAX_NUDGE_ELEVATION_DEG))
        return moved(light, "direction",
                     sun_direction(azimuth + right * NUDGE_DEG * step, elevation))
    y = math.radians(yaw)
    level_forward = np.array([math.sin(y), 0.0, -math.cos(y)])
    level_right = np.array([math.cos(y), 0.0, math.sin(y)])
    offset = (right * level_right + up * np.array([0.0, 1.0, 0.0])
              + away * level_forward) * NUDGE_M * step
    return moved(light, "position", light.position + offset)


@dataclass(frozen=True)
class LightRow:
    """One light's line in the list: what it is and what its maps did this frame."""

    index: int
    kind: str
    on: bool
    maps: int        # its maps in the frame's plan
    redrawn: int     # of those, re-rendered this frame (the rest came from the cache)


def light_rows(lights: list[Light], lights_on: list[bool], plan: ShadowPlan | None,
               spans: list[LightSpan]) -> list[LightRow]:
    """Every light's row, from the last frame's plan and each light's span of it."""
    fresh = set(plan.render_static) | set(plan.render_dynamic) if plan is not None else set()
    rows = []
    for k, light in enumerate(lights):
        span = spans[k] if k < len(spans) else LightSpan(0, 0, 0)
        end = span.first_map + span.map_count
        rows.append(LightRow(k, light.kind, lights_on[k], span.map_count,
                             sum(1 for i in fresh if span.first_map <= i < end)))
    return rows


def describe(light: Light) -> str:
    """The selected light in a few words: kind, colour and intensity, range."""
    reach = f", range {light.range:g} m" if light.range is not None else ""
    colour = ", ".join(f"{c:.2f}" for c in light.color)
    return f"{light.kind}, colour ({colour}) x {light.intensity:g}{reach}"


class LightEditor:
    """Draws the lights tab; the changes go into the overlay's :class:`Changes`."""

    def __init__(self) -> None:
        self.rows: list[LightRow] = []   # the list as last drawn
        # Where each light's switch was drawn (x0, y0, x1, y1, window pixels): tests click them.
        self.switches: dict[int, tuple[float, float, float, float]] = {}
        # Where the selected light's drags were drawn, by field, as the switches.
        self.drags: dict[str, tuple[float, float, float, float]] = {}

    def draw(self, renderer: Renderer, selected: int, changes: Changes) -> None:
        """The list of lights, then the drags of light ``selected``."""
        lights = renderer.scene.lights
        selected = min(max(selected, 0), len(lights) - 1)
        self.rows = light_rows(lights, renderer.lights_on, renderer.last_plan,
                               renderer.last_spans)
        self._draw_list(selected, changes)
        if changes.selected_light is not None:
            selected = changes.selected_light
        light = lights[selected]
        imgui.text_wrapped(f"light {selected}: {describe(light)}")
        self.drags = {}
        for field in MOVED_FIELDS[light.kind]:
            value = [float(v) for v in getattr(light, field)]
            speed = POSITION_DRAG_M if field == "position" else DIRECTION_DRAG
            changed, value = imgui.drag_float3(f"{field}##light", value, speed, 0.0, 0.0,
                                               "%.2f" if field == "position" else "%.3f")
            low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
            self.drags[field] = (low.x, low.y, high.x, high.y)
            new = moved(light, field, value) if changed else None
            if new is not None:
                light = changes.lights[selected] = new
        imgui.push_text_wrap_pos(0.0)
        imgui.text_disabled(KEYS_HINT)
        imgui.pop_text_wrap_pos()

    def _draw_list(self, selected: int, changes: Changes) -> None:
        flags = (imgui.TableFlags_.sizing_stretch_prop.value
                 | imgui.TableFlags_.borders_inner_h.value)
        rows = len(self.rows)
        outer = None
        if rows > LIST_ROWS:  # a long list scrolls inside its own box, its header kept
            flags |= imgui.TableFlags_.scroll_y.value
            line = imgui.get_frame_height_with_spacing()
            outer = imgui.ImVec2(0.0, (LIST_ROWS + 1) * line)
        self.switches = {}
        if not imgui.begin_table("lights", 4, flags, outer):
            return
        imgui.table_setup_scroll_freeze(0, 1)
        for name in ("light", "on", "maps", "redrawn"):
            imgui.table_setup_column(name)
        imgui.table_headers_row()
        for row in self.rows:
            imgui.table_next_row()
            imgui.table_next_column()
            if imgui.radio_button(f"{row.index} {row.kind}##select{row.index}",
                                  row.index == selected):
                changes.selected_light = row.index
            imgui.table_next_column()
            changed, on = imgui.checkbox(f"##on{row.index}", row.on)
            low, high = imgui.get_item_rect_min(), imgui.get_item_rect_max()
            self.switches[row.index] = (low.x, low.y, high.x, high.y)
            if changed:
                changes.lights_on[row.index] = on
            imgui.table_next_column()
            imgui.text(str(row.maps))
            imgui.table_next_column()
            imgui.text(str(row.redrawn))
        imgui.end_table()
