"""The window's lights: the panel's lights tab (a switch per light, one light moved by a drag),
the light keys, and the HUD's count of lights.

The panel is driven headless in the session context with mouse events fed to imgui, so that a
click or a drag goes through the same controls a user's does; the keys go through a real window
on GLFW's null platform (tests/app/window_driver.py, in its own process).
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from game.app.window import camera_control, light_editor
from game.app.window.glfw_setup import KEY_NAMES
from game.scene import Light, parse_scene
from game.shadows.plan import KIND_CHARACTER
from tests.app.window_helpers import DRIVER, NO_WINDOW, window_env
from tests.helpers import ROOT, SMALL_SIZE, TINY

# Light 1 of the two-light scene: a warm lamp beside the box, whose pool of light ends at its
# range; the sun, light 0, is dimmed so that the pool shows.
LAMP = """
intensity = 0.3

[[light]]
kind = "point"
position = [2.0, 2.5, 2.5]
range = 6.0
color = [1.0, 0.8, 0.5]
intensity = {intensity}
"""
LAMP_INTENSITY = 2.0
# A panel display tall enough that the lights tab shows without scrolling, at font scale 1.
PANEL_DISPLAY = (960, 1080)
FRAMES_TO_SETTLE = 3   # imgui measures a window's content in one frame and uses it the next
HUD_SIZES = [(960, 540), (320, 180)]
LIT_BY_THE_LAMP = 8    # levels of 255 that a pixel of the pool gains from the lamp, at least


def two_lights(intensity: float = LAMP_INTENSITY) -> str:
    """tests/scenes/tiny.toml with its sun as light 0 of a [[light]] array and a lamp after it."""
    text = TINY.read_text()
    head, tail = text.split("[linear_light]")
    return (head.replace("[light]\n", "[[light]]\n")
            + LAMP.format(intensity=intensity) + "\n[linear_light]" + tail)


def many_lights(count: int) -> str:
    """The two-light scene with ``count - 2`` more lamps in a row."""
    lamps = "".join(f'\n[[light]]\nkind = "point"\nposition = [{-4.0 + k}, 2.0, -2.0]\n'
                    "range = 3.0\n" for k in range(count - 2))
    head, tail = two_lights().split("[linear_light]")
    return head + lamps + "\n[linear_light]" + tail


# -- no GL ---------------------------------------------------------------------------------
POINT = Light("point", None, np.array([1.0, 2.0, 3.0]), None, range=5.0)
SUN = Light("directional", np.array([0.0, -0.8, -0.6]), None, None)
TINY_CAMERA = parse_scene(TINY.read_text()).camera


def test_light_keys_are_commands_and_take_no_other_key():
    others = {"escape", "f12", "p", "r", "tab", "m", "f1", "shift", *camera_control.MOTION_KEYS}
    assert not others & camera_control.LIGHT_KEYS.keys()
    assert set(camera_control.LIGHT_KEYS) <= set(KEY_NAMES.values())
    c = camera_control.CameraController(TINY_CAMERA)
    commands = [c.key(name, True) for name in ("left", "right", "up", "down", "page_up",
                                               "page_down", "[", "]", "l")]
    assert commands == ["light_left", "light_right", "light_forward", "light_back", "light_up",
                        "light_down", "light_previous", "light_next", "light_switch"]
    assert set(commands[:6]) == set(light_editor.NUDGES)
    assert not c.moved and not c.held   # the camera stays where it was


def test_moved_makes_a_new_light_only_for_a_new_usable_value():
    assert light_editor.moved(POINT, "position", [1.0, 2.0, 3.0]) is None
    new = light_editor.moved(POINT, "position", [1.0, 2.5, 3.0])
    np.testing.assert_array_equal(new.position, [1.0, 2.5, 3.0])
    assert (new.kind, new.range) == (POINT.kind, POINT.range)
    assert light_editor.moved(POINT, "position", [np.nan, 0.0, 0.0]) is None
    turned = light_editor.moved(SUN, "direction", [0.0, -2.0, 0.0])
    np.testing.assert_array_equal(turned.direction, [0.0, -1.0, 0.0])   # normalised
    assert light_editor.moved(SUN, "direction", [0.0, 0.0, 0.0]) is None
    down = dataclasses.replace(SUN, direction=np.array([0.0, -1.0, 0.0]))
    assert light_editor.moved(down, "direction", [0.0, -3.0, 0.0]) is None  # the same way
    with pytest.raises(ValueError):
        light_editor.moved(SUN, "position", [0.0, 0.0, 0.0])


def test_nudges_move_a_lamp_with_the_view_and_turn_a_sun():
    step = light_editor.NUDGE_M
    cases = {(0.0, "light_right"): [step, 0, 0], (0.0, "light_forward"): [0, 0, -step],
             (90.0, "light_right"): [0, 0, step], (90.0, "light_back"): [-step, 0, 0],
             (45.0, "light_up"): [0, step, 0], (45.0, "light_down"): [0, -step, 0]}
    for (yaw, command), offset in cases.items():
        new = light_editor.nudged(POINT, command, yaw)
        np.testing.assert_allclose(new.position - POINT.position, offset, atol=1e-12)
    fast = light_editor.nudged(POINT, "light_left", 0.0, step=4.0)
    np.testing.assert_allclose(fast.position - POINT.position, [-4 * step, 0, 0])
    azimuth, elevation = light_editor.sun_angles(SUN.direction)
    turned = light_editor.nudged(SUN, "light_right", 0.0)
    assert np.linalg.norm(turned.direction) == pytest.approx(1.0)
    a, e = light_editor.sun_angles(turned.direction)
    assert (a, e) == (pytest.approx(azimuth + light_editor.NUDGE_DEG), pytest.approx(elevation))
    a, e = light_editor.sun_angles(light_editor.nudged(SUN, "light_forward", 0.0).direction)
    assert e == pytest.approx(elevation + light_editor.NUDGE_DEG)
    assert light_editor.nudged(SUN, "light_up", 0.0) is None   # a sun has no height
    high = dataclasses.replace(SUN, direction=np.array([0.0, -1.0, 0.0]))
    for _ in range(3):   # never past straight down
        high = light_editor.nudged(high, "light_forward", 0.0) or high
    assert light_editor.sun_angles(high.direction)[1] == pytest.approx(
        light_editor.MAX_NUDGE_ELEVATION_DEG)


def test_light_rows_count_each_lights_maps_and_the_re_rendered_ones():
    from game.shadows.lights import LightSpan

    plan = dataclasses.make_dataclass("Plan", ["render_static", "render_dynamic"])([0, 4], [1, 5])
    spans = [LightSpan(0, 3, 0), LightSpan(3, 1, 2), LightSpan(4, 2, 3)]
    rows = light_editor.light_rows([SUN, POINT, POINT], [True, False, True], plan, spans)
    assert [(r.index, r.kind, r.on, r.maps, r.redrawn) for r in rows] == [
        (0, "directional", True, 3, 2), (1, "point", False, 1, 0), (2, "point", True, 2, 2)]
    assert [r.maps for r in light_editor.light_rows([SUN], [True], None, [])] == [0]


# -- the panel and the HUD, headless in the session context ----------------------------------

class Panel:
    """A renderer of a scene and the overlay's panel on its lights tab, fed mouse events as a
    window's backend would feed them; frames at SMALL_SIZE."""

    def __init__(self, ctx, text: str, panel: bool = True):
        from game.app.window.overlay import Overlay
        from game.render.renderer import Renderer, View

        self.scene = parse_scene(text)
        self.renderer = Renderer(ctx, self.scene, SMALL_SIZE)
        self.view = View.from_camera(self.scene.camera, SMALL_SIZE)
        self.overlay = Overlay(panel=panel, open_tab="lights")
        self.selected_light = 0   # the window state that Changes.apply sets
        self.paused = False
        self.render()

    def render(self) -> np.ndarray:
        """A frame at scene time 0, then the overlay drawn over it for a few frames."""
        self.frame = self.renderer.render(0.0, self.view)
        for _ in range(FRAMES_TO_SETTLE):
            self.draw()
        return self.frame.image.astype(int)

    def draw(self, *events, display=PANEL_DISPLAY):
        """One overlay frame after ``events`` (calls on imgui's io); its changes applied."""
        from imgui_bundle import imgui

        from game.app.window.figures import Figures

        imgui.set_current_context(self.overlay.context)
        io = imgui.get_io()
        for event in events:
            event(io)
        figures = Figures.of(self.frame, "cpu-finish", 30.0)
        changes = self.overlay.draw(figures, self.renderer, False, display, 1 / 30,
                                    selected_light=self.selected_light)
        changes.apply(self.renderer, self)
        return changes

    def click(self, x: float, y: float):
        """Press and release the left button at (x, y); the changes of the release."""
        self.draw(lambda io: io.add_mouse_pos_event(x, y),
                  lambda io: io.add_mouse_button_event(0, True))
        return self.draw(lambda io: io.add_mouse_button_event(0, False))

    def switch(self, index: int):
        x0, y0, x1, y1 = self.overlay.lights.switches[index]
        return self.click((x0 + x1) / 2, (y0 + y1) / 2)

    def drag(self, field: str, pixels: float):
        """Drag the x of the selected light's ``field`` right by ``pixels``; each step's
        changes."""
        x0, y0, x1, y1 = self.overlay.lights.drags[field]
        x, y = x0 + 10, (y0 + y1) / 2    # inside the first of the three numbers
        steps = [self.draw(lambda io: io.add_mouse_pos_event(x, y),
                           lambda io: io.add_mouse_button_event(0, True))]
        steps.append(self.draw(lambda io: io.add_mouse_pos_event(x + pixels, y)))
        steps.append(self.draw())   # held still: no change
        steps.append(self.draw(lambda io: io.add_mouse_button_event(0, False)))
        return steps

    def close(self) -> None:
        self.overlay.release()
        self.renderer.release()


@pytest.fixture
def two(ctx):
    panel = Panel(ctx, two_lights())
    yield panel
    panel.close()


def test_the_lights_tab_lists_every_light_and_its_maps(two):
    rows = two.overlay.lights.rows
    plan, spans = two.renderer.last_plan, two.renderer.last_spans
    assert [(r.index, r.kind, r.on) for r in rows] == [(0, "directional", True),
                                                      (1, "point", True)]
    assert [r.maps for r in rows] == [s.map_count for s in spans] and rows[1].maps >= 1
    assert sum(r.maps for r in rows) == len(plan.maps)
    # The panel's first frame rendered every map; the figures are of the frame drawn.
    assert sum(r.redrawn for r in rows) == len(plan.render_static) + len(plan.render_dynamic)
    assert set(two.overlay.lights.switches) == {0, 1}
    assert set(two.overlay.lights.drags) == {"direction"}   # light 0, a sun, is selected
    lay = two.overlay.layout
    assert lay.scroll_max == (0.0, 0.0), lay   # all of it shows at PANEL_DISPLAY


def test_switching_the_lamp_off_in_the_panel_takes_its_pool_away_and_on_brings_it_back(two, ctx):
    lit = two.render()
    assert two.switch(1).lights_on == {1: False}
    assert two.renderer.lights_on == [True, False]
    off = two.render()
    assert two.overlay.lights.rows[1].on is False
    # Off, the picture is the same scene's with a dark lamp (same maps: intensity never
    # changes a shadow) ...
    dark = Panel(ctx, two_lights(intensity=0.0))
    try:
        reference = dark.frame.image.astype(int)
    finally:
        dark.close()
    assert np.abs(off - reference).max() <= 1
    # ... and the lamp's pool is gone: pixels it lit are darker, none brighter.
    pool = (lit - off).max(axis=2) >= LIT_BY_THE_LAMP
    assert pool.mean() > 0.02, pool.mean()
    assert (off - lit).max() <= 1
    assert two.switch(1).lights_on == {1: True}
    np.testing.assert_array_equal(two.render(), lit)


def test_dragging_a_lamp_re_renders_its_maps_only(two):
    renderer = two.renderer
    two.render()   # a second frame: every static map is cached by now
    assert renderer.last_plan.render_static == []
    x0, y0, x1, y1 = two.overlay.lights.switches[1]
    assert two.click(30, (y0 + y1) / 2).selected_light == 1   # the lamp's radio button
    assert set(two.overlay.lights.drags) == {"position"}
    before = renderer.scene.lights[1].position.copy()
    sun = renderer.scene.lights[0]
    pixels = 20
    steps = two.drag("position", pixels)
    # A light is handed to the renderer only on the frame it moved.
    assert [list(s.lights) for s in steps] == [[], [1], [], []]
    moved = renderer.scene.lights[1]
    expected = before + [pixels * light_editor.POSITION_DRAG_M, 0, 0]
    np.testing.assert_allclose(moved.position, expected, atol=1e-6)
    assert renderer.scene.lights[0] is sun
    two.frame = renderer.render(0.0, two.view)
    plan, spans = renderer.last_plan, renderer.last_spans
    lamp = range(spans[1].first_map, spans[1].first_map + spans[1].map_count)
    statics = [i for i in lamp if plan.maps[i].kind != KIND_CHARACTER]
    assert statics and set(statics) <= set(plan.render_static)
    assert set(plan.render_static) <= set(lamp)   # light 0's maps stay cached
    two.draw()
    rows = two.overlay.lights.rows
    assert rows[1].redrawn == rows[1].maps
    assert rows[0].redrawn == sum(1 for i in plan.render_dynamic
                                  if i < spans[0].first_map + spans[0].map_count)


def test_the_hud_counts_the_lights_within_its_share(ctx):
    one = Panel(ctx, TINY.read_text(), panel=False)
    two = Panel(ctx, two_lights(), panel=False)
    try:
        for size in HUD_SIZES:
            for _ in range(FRAMES_TO_SETTLE):
                one.draw(display=size)
                two.draw(display=size)
            x, y, w, h = two.overlay.rect
            assert w * h <= size[0] * size[1] / 12
            if size == HUD_SIZES[0]:
                assert "2 lights" in two.overlay.hud_lines[-1], two.overlay.hud_lines
                assert "lights" not in " ".join(one.overlay.hud_lines)
        two.renderer.lights_on[1] = False
        two.draw(display=HUD_SIZES[0])
        assert "2 lights, 1 off" in two.overlay.hud_lines[-1]
    finally:
        one.close()
        two.close()


@pytest.mark.parametrize("size", [(960, 540), (320, 180)], ids=lambda s: f"{s[0]}x{s[1]}")
def test_a_long_list_of_lights_fits_the_panels_width_and_scrolls(ctx, size):
    panel = Panel(ctx, many_lights(light_editor.LIST_ROWS + 4))
    try:
        for _ in range(FRAMES_TO_SETTLE):
            panel.draw(display=size)
        x, y, w, h = panel.overlay.rect
        assert w * h <= size[0] * size[1] / 3
        lay = panel.overlay.layout
        assert lay.scroll_max[0] == 0, lay
        assert len(panel.overlay.lights.rows) == light_editor.LIST_ROWS + 4
    finally:
        panel.close()


# -- the light keys in a real window ---------------------------------------------------------
def test_light_keys_select_nudge_and_switch_a_lamp_in_the_window(tmp_path):
    scene = tmp_path / "two_lights.toml"
    scene.write_text(two_lights())
    result = subprocess.run([sys.executable, str(DRIVER), str(scene), "lights"],
                            capture_output=True, text=True, timeout=300, env=window_env(), cwd=ROOT)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout.strip().splitlines()[-1])
    assert seen["tab"] == "lights"   # a scene of several lights opens the panel there
    assert seen["selected"] == [1, 0]   # "]" from light 0, then "[" back
    # Right arrow pressed and repeated once, then released: two nudges along the view's right.
    offset = np.array(seen["lamp_after"]) - np.array(seen["lamp_before"])
    yaw = np.radians(seen["yaw"])
    right = np.array([np.cos(yaw), 0.0, np.sin(yaw)])
    np.testing.assert_allclose(offset, 2 * light_editor.NUDGE_M * right, atol=1e-9)
    lamp = range(seen["lamp_span"][0], seen["lamp_span"][0] + seen["lamp_span"][1])
    assert seen["render_static"] and set(seen["render_static"]) <= set(lamp)
    assert seen["lights_on"] == [True, False]
    assert seen["gl_error"] == "GL_NO_ERROR"
