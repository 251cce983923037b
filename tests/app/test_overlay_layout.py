"""The overlay's two modes: a HUD that covers at most a twelfth of the window, and a panel (F1)
that covers at most a third, scales with the window and scrolls what it cannot show.

Layout is checked headless in the session context (imgui lays out for any display size without a
window), the HUD's bar in the pixels it draws, and F1 in a real window on GLFW's null platform
(tests/app/window_driver.py, in its own process).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from tests.app.window_helpers import DRIVER, NO_WINDOW, window_env
from tests.helpers import ROOT, SMALL_SIZE, TINY

SIZES = [(960, 540), (640, 360), (320, 180), (1920, 1080)]
# Every pass the panel can list, so that the graph's legend is as tall as it gets.
ALL_PASSES = {"shadow_static": 0.5, "shadow_dynamic": 2.0, "cull": 0.4, "shade": 6.0,
              "traced_build": 0.3, "traced_trace": 3.0, "soft_build": 0.2, "soft_trace": 4.0,
              "composite": 1.0, "total": 17.5, "present": 1.0, "overlay": 0.8}
FRAMES_TO_SETTLE = 3   # imgui measures a window's content in one frame and uses it the next
MIN_LINE_PIXELS = 9    # imgui's 13-pixel font at the overlay's smallest scale, 0.75


@pytest.fixture(scope="module")
def small_frame(gl_session):
    """A renderer of tests/scenes/tiny.toml and its first frame at SMALL_SIZE."""
    from game.render.renderer import Renderer, View
    from game.scene import load_scene

    scene = load_scene(TINY)
    renderer = Renderer(gl_session, scene, SMALL_SIZE)
    frame = renderer.render(0.0, View.from_camera(scene.camera, SMALL_SIZE))
    yield renderer, frame
    renderer.release()


def _figures(ms: dict[str, float]):
    from game.app.window.figures import Figures

    return Figures(ms=dict(ms), clock="cpu-finish", maps_rendered=7, maps_cached=5,
                   triangles_to_maps=3584, maps_per_fragment=0.25, fps=57.1,
                   texels_to_maps=1835008)


def _drawn(renderer, ms: dict[str, float], size, panel: bool, tab: str = "view"):
    from game.app.window.overlay import Overlay

    overlay = Overlay(panel=panel, open_tab=tab)
    for _ in range(FRAMES_TO_SETTLE):
        overlay.draw(_figures(ms), renderer, False, size, 1 / 30)
    return overlay


def test_panel_extent_scales_with_the_window_and_keeps_to_a_third():
    from game.app.window.imgui_layout import PANEL_MARGIN
    from game.app.window.panel import panel_extent

    for size in [*SIZES, (200, 120), (3840, 2160), (1080, 1920)]:
        w, h = panel_extent(size)
        assert w * h <= size[0] * size[1] / 3, size
        assert 0 < w <= size[0] - 2 * PANEL_MARGIN and 0 < h <= size[1] - 2 * PANEL_MARGIN
    # A wide window: the panel is as tall as the window allows and grows with it.
    small, large = panel_extent((960, 540)), panel_extent((1920, 1080))
    assert small[1] == 540 - 2 * PANEL_MARGIN and large[1] == 1080 - 2 * PANEL_MARGIN
    assert large[0] == pytest.approx(2 * small[0], abs=1)


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_hud_covers_at_most_a_twelfth_of_the_window(ctx, small_frame, size):
    renderer, frame = small_frame
    overlay = _drawn(renderer, frame.ms, size, panel=False)
    try:
        x, y, w, h = overlay.rect
        assert w * h <= size[0] * size[1] / 12
        assert x >= 0 and y >= 0 and x + w <= size[0] and y + h <= size[1]
        assert w > 50 and h > 10          # and it is there
        assert overlay.bar, "no bar"      # every pass of the frame in it, inside the box
        for segment in overlay.bar:
            assert x <= segment.x0 <= segment.x1 <= x + w + 0.5
            assert y <= segment.y0 < segment.y1 <= y + h
    finally:
        overlay.release()


@pytest.mark.parametrize("tab", ["view", "shadows", "lights", "maps"])
@pytest.mark.parametrize("size", SIZES[:3], ids=lambda s: f"{s[0]}x{s[1]}")
def test_panel_covers_at_most_a_third_and_scrolls_what_does_not_fit(ctx, small_frame, size,
                                                                    tab):
    renderer, _ = small_frame
    overlay = _drawn(renderer, ALL_PASSES, size, panel=True, tab=tab)
    try:
        x, y, w, h = overlay.rect
        assert w * h <= size[0] * size[1] / 3
        assert x + w <= size[0] and y + h <= size[1]
        lay = overlay.layout
        needed = [lay.content[i] + 2 * lay.padding[i] for i in (0, 1)]
        # Its rows fit its width: nothing is cut at the right edge.
        assert needed[0] <= lay.inner[0] + 1 and lay.scroll_max[0] == 0, lay
        # What is taller than the panel scrolls, with a scrollbar, down to its end.
        assert needed[1] <= lay.inner[1] + lay.scroll_max[1] + 1, lay
        if needed[1] > lay.inner[1] + 1:
            assert lay.scrollbars[1], lay
        # The graph's legend (every pass) is whole, within its plot and the panel's width ...
        assert lay.legend == lay.legend_shown, lay
        x0, y0, x1, y1 = lay.legend
        assert x <= x0 < x1 <= x + w
        assert y1 - y0 > len(ALL_PASSES) * MIN_LINE_PIXELS   # a line for every pass
        # ... shown whole once scrolled to, and at 960x540 without scrolling.
        assert y <= y0 < y1 <= y + h + lay.scroll_max[1], (lay.legend, overlay.rect)
        if size[1] >= 540:
            assert y1 <= y + h, (lay.legend, overlay.rect)
    finally:
        overlay.release()


def test_hud_bar_draws_a_segment_per_pass_in_its_colour(ctx):
    from game.app.window.overlay import Overlay
    from game.render.renderer import Renderer, View
    from game.scene import load_scene

    size = (480, 270)
    ms = {"shadow_static": 2.0, "shadow_dynamic": 3.0, "cull": 1.0, "shade": 4.0,
          "total": 12.0, "present": 1.0, "overlay": 1.0}   # 2 ms of the frame in no pass
    scene = load_scene(TINY)
    renderer = Renderer(ctx, scene, size)
    overlay = Overlay(panel=False)
    try:
        frame = renderer.render(0.0, View.from_camera(scene.camera, size))
        for _ in range(2):
            overlay.draw(_figures(ms), renderer, False, size, 1 / 30)
        framebuffer, _ = renderer.display
        framebuffer.use()
        overlay.render()
        data = framebuffer.read(viewport=(0, 0, *size), components=3)
        image = np.frombuffer(data, np.uint8).reshape(size[1], size[0], 3)[::-1].astype(int)
        bar = overlay.bar
        assert [s.name for s in bar] == ["shadow_static", "shadow_dynamic", "cull", "shade"]
        width = (bar[-1].x1 - bar[0].x0) * 12.0 / 10.0      # the whole bar is the total
        for segment in bar:
            assert segment.x1 - segment.x0 == pytest.approx(width * ms[segment.name] / 12.0)
        for left, right in zip(bar, bar[1:], strict=False):
            assert right.x0 == pytest.approx(left.x1)
            assert left.colour != right.colour
        for segment in bar:
            cx, cy = int((segment.x0 + segment.x1) / 2), int((segment.y0 + segment.y1) / 2)
            expected = np.round(np.array(segment.colour) * 255)
            assert np.abs(image[cy, cx] - expected).max() <= 2, (segment, image[cy, cx])
            # ... which the scene under it is not.
            assert np.abs(frame.image[cy, cx].astype(int) - expected).max() > 8
    finally:
        overlay.release()
        renderer.release()


@pytest.fixture(scope="module")
def modes():
    """F1 in a real window (tests/app/window_driver.py overlay_modes), as the JSON it printed."""
    result = subprocess.run([sys.executable, str(DRIVER), str(TINY), "overlay-modes"],
                            capture_output=True, text=True, timeout=300, env=window_env(), cwd=ROOT)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def _share(seen: dict) -> float:
    x, y, w, h = seen["rect"]
    return w * h / (seen["size"][0] * seen["size"][1])


def test_f1_opens_and_closes_the_panel_in_the_window(modes):
    assert modes["f1"] == "f1"
    hud, panel = modes["hud"], modes["panel"]
    resized, hud_again = modes["panel_resized"], modes["hud_resized"]
    assert [hud["panel"], panel["panel"], resized["panel"], hud_again["panel"]] == [
        False, True, True, False]
    assert hud["size"] == panel["size"] == [640, 360]
    assert resized["size"] == hud_again["size"] == [960, 540]
    assert 0 < _share(hud) <= 1 / 12 and 0 < _share(hud_again) <= 1 / 12
    assert 1 / 12 < _share(panel) <= 1 / 3 and 1 / 12 < _share(resized) <= 1 / 3
    # The panel follows the window's size.
    assert resized["rect"][2] > panel["rect"][2] and resized["rect"][3] > panel["rect"][3]
    assert hud["bar"][:4] == ["shadow_static", "shadow_dynamic", "cull", "shade"]
    # The window's own controls (render scale, soft shadows) make it taller: it scrolls.
    lay = resized["layout"]
    assert lay["scroll_max"][0] == 0
    assert lay["content"][1] + 2 * lay["padding"][1] <= lay["inner"][1] + lay["scroll_max"][1] + 1


def test_play_panel_opens_with_the_panel(modes):
    opened = modes["opened_with_panel"]
    assert opened["panel"] and 0 < _share(opened) <= 1 / 3
