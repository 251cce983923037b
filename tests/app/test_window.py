"""The walkaround: the camera controller without GL, then the real window with no display.

The window runs on GLFW's null platform with an EGL context (imgui-bundle's GLFW 3.5), each run
in its own process so that its context never meets the session's headless one. Input is
scripted through the same methods the glfw callbacks call (tests/app/window_driver.py).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from game import transforms
from game.app.window import camera_control
from game.scene import Camera
from tests.app.window_helpers import DRIVER, NO_WINDOW, WIDE, run_game, window_env
from tests.cli.cli_helpers import in_process
from tests.helpers import ROOT, TINY, read_png

# -- the controller, no GL --------------------------------------------------------------------
CAMERA = Camera(position=np.array([0.0, 2.0, 10.0]), target=np.array([0.0, 1.0, 0.0]))


def test_controller_starts_at_the_scene_view_exactly():
    c = camera_control.CameraController(CAMERA)
    np.testing.assert_array_equal(c.view_matrix(),
                                  transforms.look_at(CAMERA.position, CAMERA.target))
    # The free-fly camera looks the same way, up to rounding.
    np.testing.assert_allclose(c.camera.view_matrix(), c.view_matrix(), atol=1e-9)


def test_keys_move_along_the_view_and_shift_is_faster():
    c = camera_control.CameraController(CAMERA)
    forward = c.camera.forward()
    c.key("w", True)
    c.update(0.5)
    step = c.camera.position - CAMERA.position
    np.testing.assert_allclose(step, forward * camera_control.MOVE_SPEED_M_S * 0.5)
    c.key("shift", True)
    before = c.camera.position.copy()
    c.update(0.5)
    fast = np.linalg.norm(c.camera.position - before)
    assert fast == pytest.approx(camera_control.MOVE_SPEED_M_S * camera_control.FAST_FACTOR * 0.5)
    c.key("w", False)
    c.key("shift", False)
    c.key("e", True)
    before = c.camera.position.copy()
    c.update(1.0)
    np.testing.assert_allclose(c.camera.position - before, [0, camera_control.MOVE_SPEED_M_S, 0])
    c.key("e", False)
    c.key("d", True)
    before = c.camera.position.copy()
    c.update(1.0)
    right = c.camera.position - before
    assert right @ forward == pytest.approx(0.0, abs=1e-9) and right[0] > 0


def test_mouse_turns_only_while_looking_and_r_resets():
    c = camera_control.CameraController(CAMERA)
    yaw, pitch = c.camera.yaw, c.camera.pitch
    c.mouse_move(100, 100)
    c.mouse_move(200, 100)
    assert (c.camera.yaw, c.camera.pitch) == (yaw, pitch)
    c.mouse_button(True)
    c.mouse_move(100, 100)
    c.mouse_move(200, 50)
    assert c.camera.yaw == pytest.approx(yaw + 100 * camera_control.LOOK_DEG_PER_PIXEL)
    assert c.camera.pitch == pytest.approx(pitch + 50 * camera_control.LOOK_DEG_PER_PIXEL)
    for _ in range(100):  # never past straight up
        c.mouse_move(200, -1e4)
        c.mouse_move(200, 50)
    assert c.camera.pitch <= camera_control.MAX_PITCH_DEG
    assert c.key("r", True) == "reset"
    np.testing.assert_array_equal(c.view_matrix(),
                                  transforms.look_at(CAMERA.position, CAMERA.target))


def test_command_keys():
    c = camera_control.CameraController(CAMERA)
    assert [c.key(k, True) for k in ("escape", "f12", "p", "m")] == [
        "quit", "screenshot", "pause", "next_method"]
    assert c.key("escape", False) is None
    assert c.key("tab", True) == "capture_cursor" and c.captured
    c.mouse_move(0, 0)
    c.mouse_move(10, 0)
    assert c.moved


def test_sun_angles_round_trip():
    from game.app.window.light_editor import sun_angles, sun_direction

    d = np.array([-0.4, -1.0, -0.3])
    d /= np.linalg.norm(d)
    np.testing.assert_allclose(sun_direction(*sun_angles(d)), d, atol=1e-12)
    assert sun_angles(np.array([0.0, -1.0, 0.0]))[1] == pytest.approx(90.0)


# -- the real window, no display ---------------------------------------------------------------
@pytest.fixture(scope="module")
def driven():
    """One scripted run of the window (tests/app/window_driver.py), as the JSON it printed."""
    result = subprocess.run([sys.executable, str(DRIVER), str(TINY)], capture_output=True,
                            text=True, timeout=300, env=window_env(), cwd=ROOT)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_the_window_shows_what_its_screenshots_hold(tmp_path):
    result = subprocess.run([sys.executable, str(DRIVER), str(TINY), str(tmp_path)],
                            capture_output=True, text=True, timeout=300, env=window_env(), cwd=ROOT)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout.strip().splitlines()[-1])
    for scale in ("1.0", "0.5"):
        assert seen[scale]["screenshot_vs_window"] == 0
        # The same FXAA draw into the window's surface and into the canvas texture: llvmpipe
        # compiles the shader anew for each target format, and where FXAA's test of the blur
        # against the neighbourhood's luma range sits on a knife edge, the two may choose
        # different blurs: at most a level of 255 apart, on a few pixels.
        assert seen[scale]["direct_vs_canvas"] <= 1
        assert 20 < seen[scale]["mean"] < 235   # the scene, not a blank window
    assert len(list(tmp_path.glob("screenshot_*.png"))) == 2


def test_scripted_keys_move_the_camera(driven):
    positions = np.array(driven["positions"])
    np.testing.assert_array_equal(positions[3], positions[0])      # nothing held yet
    moved = positions[14] - positions[3]                            # W held for ten frames
    expected = camera_control.MOVE_SPEED_M_S * 10 / 30.0
    assert np.linalg.norm(moved) == pytest.approx(expected, rel=1e-6)
    np.testing.assert_array_equal(positions[-1], positions[14])     # W released


def test_method_switch_key(driven):
    assert driven["methods"][15] == "clumped"
    assert driven["methods"][16] == "single"


def test_overlay_figures_are_populated(driven):
    f = driven["figures"]
    for name in ("shadow_static", "shadow_dynamic", "shade", "total", "overlay"):
        assert f["ms"][name] >= 0
    assert f["ms"]["total"] > 0 and f["ms"]["total"] >= f["ms"]["shade"]
    assert f["clock"] in ("cpu-finish", "gpu-query")
    assert f["maps_rendered"] >= 1 and f["triangles_to_maps"] > 0
    assert 0 < f["maps_per_fragment"] <= 1.0   # single: one map, read where it covers
    assert f["fps"] > 0
    # The window opens with the overlay's HUD (F1 opens the panel: tests/app/test_overlay_layout.py)
    x, y, w, h = driven["overlay_rect"]
    width, height = driven["framebuffers"][-1]
    assert w > 50 and h > 10 and w * h <= width * height / 12


def test_settings_the_gl_refuses_are_undone_and_shown(driven):
    # Undone by the window (message in the panel), or fitted to the GL by the renderer (a note,
    # which the panel shows too); either way the window lives on at a size the GL can take.
    refused = driven["refused"]
    assert refused["resolution"] < 1 << 20
    assert ("GL_MAX_TEXTURE_SIZE" in refused["message"]
            or any("GL_MAX_TEXTURE_SIZE" in note or "texture size" in note.lower()
                   for note in refused["notes"])), refused


def test_resize_and_minimise_cycles(driven):
    assert driven["final_error"] == "GL_NO_ERROR"
    assert set(driven["errors"]) == {"GL_NO_ERROR"}
    # The render size follows the framebuffer, down and back up.
    sizes = [tuple(s) for s in driven["sizes"]]
    assert (200, 120) in sizes and sizes[-1] == (320, 180)
    # Before each frame, the target is the size of the framebuffer the last frame drew to.
    assert driven["sizes"][1:] == driven["framebuffers"][1:]
    assert driven["frames_while_minimised"] == 0
    assert driven["frames"] > 30


def test_screenshot_matches_a_headless_capture_outside_the_overlay(capsys, tmp_path):
    capture = in_process(capsys)   # no window: in this process
    shot, stats = tmp_path / "shot.png", tmp_path / "play.json"
    # With the capture's settings: no FXAA on the picture, no PCF on the shadows.
    result = run_game("play", TINY, "--platform", "null", "--frames", "3", "--fps", "10",
                      "--size", "640x360", "--screenshot", shot, "--stats", stats,
                      "--aa", "none", "--no-pcf")
    if result.returncode != 0 and "cannot open" in result.stderr:
        pytest.skip(result.stderr.strip())
    assert result.returncode == 0, result.stderr
    assert len(result.stdout.strip().splitlines()) == 1
    play = json.loads(stats.read_text())
    assert len(play["frames"]) == 3 and play["fps"] > 0
    assert play["frames"][-1]["time"] == pytest.approx(0.2)
    out = tmp_path / "cap"
    result = capture("capture", TINY, "--frames", "1", "--time", "0.2", "--size", "640x360",
                     "--out", out)
    assert result.returncode == 0, result.stderr
    window = read_png(shot)
    headless = read_png(out / "frame_0000.png")
    assert window.shape == headless.shape == (360, 640, 3)
    x, y, w, h = play["overlay_rect"]
    outside = np.ones(window.shape[:2], bool)
    outside[y:y + h, x:x + w] = False
    assert outside.sum() > 0.2 * outside.size
    diff = np.abs(window.astype(int) - headless.astype(int)).max(axis=2)
    assert (diff[outside] <= 1).mean() > 0.999, diff[outside].max()
    # ... and the overlay is really there.
    assert (diff[~outside] > 8).mean() > 0.2


def test_capture_overlay_draws_the_panel_into_headless_frames(capsys, tmp_path):
    capture = in_process(capsys)   # no window: in this process
    plain, over = tmp_path / "plain", tmp_path / "over"
    for out, extra in ((plain, []), (over, ["--overlay"])):
        result = capture("capture", TINY, "--frames", "2", "--size", "640x360", "--out", out,
                         *extra)
        assert result.returncode == 0, result.stderr
    a = read_png(plain / "frame_0001.png").astype(int)
    b = read_png(over / "frame_0001.png").astype(int)
    # The panel sits at the top left; the right edge of the frame is untouched.
    assert (np.abs(a - b)[20:200, 20:300].max(axis=2) > 8).mean() > 0.2
    np.testing.assert_array_equal(a[:, 420:], b[:, 420:])


def test_play_without_a_display_is_one_line(tmp_path):
    result = run_game("play", TINY, "--frames", "1")
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "window" in lines[0] and "Traceback" not in result.stderr


@pytest.mark.parametrize("args, fragment", [
    (["--screenshot", "x.png"], "--frames"),
    (["--frames", "0"], "--frames"),
    (["--size", "0x1"], "--size"),
    (["--frames", "1", "--stats", "no/such/folder/s.json"], "--stats"),
])
def test_play_bad_arguments(args, fragment):
    result = run_game("play", TINY, "--platform", "null", *args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], result.stderr


@pytest.fixture(scope="module")
def traced_soft(tmp_path_factory):
    """The window switched to ``traced`` with M, then soft shadows toggled
    (tests/app/window_driver.py traced_and_soft): what it printed and the folder of its frames."""
    out = tmp_path_factory.mktemp("traced_soft")
    result = subprocess.run([sys.executable, str(DRIVER), str(TINY), str(out), "traced-soft"],
                            capture_output=True, text=True, timeout=300, env=window_env(), cwd=ROOT)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1]), out


def _outside_panel(seen: dict, shape) -> np.ndarray:
    x, y, w, h = seen["overlay_rect"]
    outside = np.ones(shape[:2], bool)
    outside[y:y + h, x:x + w] = False
    assert outside.sum() > 0.2 * outside.size
    return outside


def test_m_cycles_to_traced_and_its_shadows_match_a_headless_traced_capture(traced_soft,
                                                                           tmp_path, capsys):
    capture = in_process(capsys)   # no window: in this process
    seen, out = traced_soft
    assert seen["methods"] == ["single", "static-dynamic", "csm", "traced"]
    assert seen["after_traced"] == "clumped"      # the cycle wraps
    traced = seen["traced"]
    assert traced["method"] == "traced" and traced["render_size"] == list(WIDE)
    assert traced["ms"]["traced_trace"] > 0 and traced["ms"]["composite"] > 0
    window = np.load(out / "traced.npy")
    outside = _outside_panel(traced, window.shape)
    result = capture("capture", TINY, "--method", "traced", "--time", "0", "--size",
                     "{}x{}".format(*WIDE), "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    captured = read_png(tmp_path / "frame_0000.png").astype(int)
    diff = np.abs(window.astype(int) - captured).max(axis=2)
    assert (diff[outside] <= 1).mean() > 0.999, diff[outside].max()
    # ... and not the maps' shadows: the driver's coarse maps shadow other pixels.
    maps = np.load(out / "clumped.npy").astype(int)
    assert (np.abs(window.astype(int) - maps).max(axis=2)[outside] > 8).sum() > 10


def test_soft_shadows_change_the_image_and_show_their_trace_time(traced_soft):
    seen, out = traced_soft
    soft, hard = seen["soft"], seen["clumped"]
    assert soft["soft"] and not hard["soft"]
    assert soft["ms"]["soft_trace"] > 0 and soft["ms"]["composite"] > 0
    assert soft["ms"]["total"] >= soft["ms"]["soft_trace"]
    assert "soft_trace" not in hard["ms"]
    # The frame at the window's resolution, traced at a quarter of it per side and upsampled.
    quarter = [WIDE[0] // 4, WIDE[1] // 4]
    assert soft["render_size"] == list(WIDE) == hard["render_size"]
    assert soft["trace_size"] == quarter and hard["trace_size"] is None
    # The HUD says at what resolution the trace ran, and how long it took.
    assert re.search(rf"\+ soft {quarter[0]}x{quarter[1]} \d+\.\d ms", soft["hud"][-1]), \
        soft["hud"]
    a, b = np.load(out / "soft.npy").astype(int), np.load(out / "clumped.npy").astype(int)
    outside = _outside_panel(hard, a.shape)
    assert (np.abs(a - b).max(axis=2)[outside] > 8).mean() > 0.05
    assert 20 < a[outside].mean() < 235   # a scene, not a blank frame


def test_toggling_soft_shadows_keeps_the_gl_object_count(traced_soft):
    seen, _ = traced_soft
    counts = seen["gl_objects"]
    assert len(set(counts["on"])) == 1 and len(set(counts["off"])) == 1, counts
    assert seen["gl_error"] == "GL_NO_ERROR"


def test_play_soft_needs_a_linear_light(tmp_path):
    scene = tmp_path / "no_linear.toml"
    scene.write_text("\n".join(line for line in TINY.read_text().splitlines()
                               if not line.startswith(("[linear_light]", "a =", "b ="))))
    result = run_game("play", scene, "--platform", "null", "--frames", "1", "--soft")
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "linear_light" in lines[0], result.stderr


# -- the overlay headless, in the session context ----------------------------------------------
def test_layer_viewer_shows_a_rendered_map_and_the_cache_state(ctx):
    from game.app.window import overlay
    from game.render.renderer import Renderer, View
    from game.scene import load_scene

    scene = load_scene(TINY)
    size = (480, 320)
    renderer = Renderer(ctx, scene, size)
    hud = overlay.Overlay(open_tab="maps")
    try:
        view = View.from_camera(scene.camera, size)
        for k in range(3):
            frame = renderer.render(k / 30, view)
            image = hud.draw_over_frame(renderer, frame, 1 / 30)
        plan = renderer.last_plan
        assert plan.render_static == [] and plan.render_dynamic  # statics cached by now
        viewer = hud.full_panel.maps.viewer
        assert viewer is not None
        depth = np.frombuffer(viewer.texture.read(), np.uint8).reshape(256, 256, 4)
        grey = depth[..., 0] > 64  # casters drawn (the cleared background is dark blue)
        assert 0.001 < grey.mean() < 0.95
        assert image.shape == (320, 480, 3) and not np.array_equal(image, frame.image)
    finally:
        hud.release()
        renderer.release()


def test_render_scale_renders_smaller_and_shows_the_window_size(tmp_path):
    shot, stats = tmp_path / "shot.png", tmp_path / "play.json"
    result = run_game("play", TINY, "--platform", "null", "--frames", "2", "--size", "320x180",
                      "--render-scale", "0.5", "--no-overlay", "--screenshot", shot,
                      "--stats", stats)
    if result.returncode != 0 and "cannot open" in result.stderr:
        pytest.skip(result.stderr.strip())
    assert result.returncode == 0, result.stderr
    play = json.loads(stats.read_text())
    assert play["size"] == [320, 180] and play["render_size"] == [160, 90]
    image = read_png(shot)
    assert image.shape == (180, 320, 3)
    # Scaled up with a linear filter: neighbouring pixels are close, yet the scene is there.
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 20


def test_cache_debug_view_colours_re_rendered_and_cached_maps(ctx):
    from game.render.renderer import Renderer, View
    from game.scene import load_scene

    scene = load_scene(TINY)
    size = (160, 90)
    renderer = Renderer(ctx, scene, size)
    renderer.debug_view = "cache"
    try:
        view = View.from_camera(scene.camera, size)
        first, second = renderer.render(0.0, view), renderer.render(0.1, view)
    finally:
        renderer.release()

    def shares(frame):
        rgb = frame.image.astype(int)
        red = (rgb[..., 0] > rgb[..., 1] + 40) & frame.covered
        green = (rgb[..., 1] > rgb[..., 0] + 40) & frame.covered
        return red.mean(), green.mean()

    # Frame 0 renders every map; frame 1 serves the clumps from the cache.
    assert first.maps_cached == 0 and second.maps_cached > 0
    red0, green0 = shares(first)
    red1, green1 = shares(second)
    assert green0 == 0 and red0 > 0.01
    assert green1 > 0.01 and red1 > 0


def test_capture_takes_the_cache_debug_view(capsys, tmp_path):
    capture = in_process(capsys)   # no window: in this process
    result = capture("capture", TINY, "--frames", "2", "--size", "160x90", "--debug-view",
                     "cache", "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    first = read_png(tmp_path / "frame_0000.png").astype(int)
    second = read_png(tmp_path / "frame_0001.png").astype(int)

    def green(rgb):  # pixels whose map came from the cache
        return (rgb[..., 1] > rgb[..., 0] + 40).mean()

    assert green(first) == 0 and green(second) > 0.01


def test_without_fps_the_scene_clock_follows_real_time(tmp_path):
    stats = tmp_path / "s.json"
    result = run_game("play", TINY, "--platform", "null", "--frames", "12", "--no-overlay",
                      "--size", "160x90", "--stats", stats)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    frames = json.loads(stats.read_text())["frames"]
    assert frames[0]["time"] == 0.0
    # The last frame shows the real time since the first one started: the frames before it,
    # each at least as long as its own drawing and at most its whole period.
    drawn = sum(f["ms"]["total"] for f in frames[:-1]) / 1e3
    periods = sum(f["frame_ms"] for f in frames[:-1]) / 1e3
    assert drawn * 0.9 <= frames[-1]["time"] <= periods * 1.5 + 0.05
