"""The machine's limits: missing EGL, no display, old GL, and shadow maps beyond the GL's
limits or the memory budget. Each either stops with one clear line or degrades with a note, and a
degraded frame still matches Embree (never a silently missing shadow)."""

from __future__ import annotations

import dataclasses

import moderngl
import pytest

from game import cli
from game.errors import GameError
from game.gpu import context
from game.gpu.limits import GLLimits
from game.render.renderer import Renderer
from game.scene import parse_scene
from game.shadows.budget import fit_settings
from game.shadows.plan import KIND_CHARACTER, ShadowSettings, layer_bytes
from tests.helpers import ACCURACY_SIZE as SIZE
from tests.helpers import MAX_ERROR
from tests.helpers import TINY as TINY_PATH
from tests.shadow_check import render_and_check

TINY = TINY_PATH.read_text()
EXTRA = [(-4.5, 3.0), (-2.5, 4.0), (0.5, 3.5), (3.0, 3.0), (4.5, 1.0)]


def crowd_scene():
    """tiny.toml plus five standing characters: six in all."""
    text = TINY + "".join(
        f'\n[[character]]\nshape = "capsule"\nradius = 0.3\nheight = 1.8\n'
        f"path = [[{x}, 0.9, {z}]]\n" for x, z in EXTRA)
    return parse_scene(text, TINY_PATH, TINY_PATH.parent)


# -- the context -------------------------------------------------------------------------------
def one_line(capsys, argv) -> tuple[int, str]:
    code = cli.main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return code, err[0]


def test_no_egl_library_says_what_to_install(capsys, monkeypatch, tmp_path):
    def fail(**kwargs):
        raise Exception("libEGL.so.1: cannot open shared object file: No such file or directory")

    monkeypatch.setattr(moderngl, "create_context", fail)
    code, line = one_line(capsys, ["capture", str(TINY_PATH), "--out", str(tmp_path)])
    assert code == 1
    assert line.startswith("error: no EGL library found") and "apt-get install libegl1" in line


def test_egl_without_a_driver_says_what_to_install(monkeypatch):
    def fail(**kwargs):
        raise Exception("eglInitialize failed: 0x3001")

    monkeypatch.setattr(moderngl, "create_context", fail)
    with pytest.raises(GameError, match="libgl1-mesa-dri"):
        context.create_headless()


class OldContext:
    """What moderngl returns on a GL 3.3 driver, as far as the version check looks."""

    version_code = 330
    info = {"GL_RENDERER": "OldGPU", "GL_VERSION": "3.3 Core"}
    released = False

    def release(self):
        self.released = True


def test_gl_below_4_3_says_what_to_use(capsys, monkeypatch, tmp_path):
    old = OldContext()
    monkeypatch.setattr(moderngl, "create_context", lambda **kwargs: old)
    code, line = one_line(capsys, ["capture", str(TINY_PATH), "--out", str(tmp_path)])
    assert code == 1
    assert "OpenGL 4.3 core is required" in line and "OldGPU" in line and "3.3 Core" in line
    assert "llvmpipe" in line  # what to use instead
    assert old.released


# -- settings inside the limits ------------------------------------------------------------------
LIMITS = GLLimits(max_texture_size=16384, max_array_layers=2048, max_maps=128)


def test_resolution_above_max_texture_size_is_clamped_with_a_note():
    s = ShadowSettings(clump_resolution=4096, character_resolution=8192)
    fitted, notes = fit_settings(s, LIMITS.tightened(max_texture_size=2048), 3)
    assert fitted.clump_resolution == 2048 and fitted.character_resolution == 2048
    assert len(notes) == 2 and all("GL_MAX_TEXTURE_SIZE" in n for n in notes)
    assert s.clump_resolution == 4096  # the caller's settings are left alone


def test_array_over_the_budget_gets_coarser_layers():
    s = ShadowSettings(clump_resolution=4096, budget_mib=64)
    fitted, notes = fit_settings(s, LIMITS, 2)
    # Two layers (a clump and a character) of 4 * res^2 bytes must fit 64 MiB: 2048 does.
    assert fitted.clump_resolution == 2048
    assert "budget" in notes[0]
    single = ShadowSettings(method="single", single_resolution=8192,
                                           budget_mib=64)
    # The budget is clumped's: a baseline keeps the resolution the comparison names.
    assert fit_settings(single, LIMITS, 2) == (single, [])


def test_settings_inside_the_limits_are_untouched():
    s = ShadowSettings()
    assert fit_settings(s, LIMITS, 7) == (s, [])


# -- frames under simulated limits, checked against Embree -----------------------------------------
def check(renderer: Renderer, t: float = 0.0):
    frame, err = render_and_check(renderer, t)
    assert err["shadowed"] >= 200
    assert err["error"] <= MAX_ERROR, err["error"]
    return frame


def test_characters_beyond_the_layer_limit_get_coarser_maps(ctx):
    """Two layers: one for the clump, one that cannot hold six character maps of 512^2 (it holds
    four). The largest are halved until all fit; every character still casts, correctly."""
    scene = crowd_scene()
    limits = GLLimits.of(ctx).tightened(max_array_layers=2)
    renderer = Renderer(ctx, scene, SIZE, ShadowSettings(clump_resolution=1024), gbuffer=True,
                        limits=limits)
    try:
        method = renderer.method
        assert method.layers <= 2
        assert any("coarser" in note for note in method.notes)
        frame = check(renderer, 0.5)
        plan = method.plan(renderer.models(0.5))  # no view: every map asks for the largest
        drawn = sorted(o for m in plan.maps for o in m.objects
                       if m.kind == KIND_CHARACTER)
        assert drawn == [renderer.geom.character_object(i) for i in range(6)]  # none dropped
        assert plan.characters.shrunk >= 2
        assert frame.maps_total >= 7 and method.layers <= 2  # seven maps in two layers
    finally:
        renderer.release()


def test_character_maps_take_at_most_half_the_budget(ctx):
    """Six characters whose largest maps each fill a layer, in a budget of eight layers: they
    get four, and the clumps keep the other four (not the two the worst case would leave)."""
    settings = ShadowSettings(clump_resolution=256, character_resolution=256,
                              budget_mib=8 * layer_bytes(256) / 2**20)
    renderer = Renderer(ctx, crowd_scene(), SIZE, settings, gbuffer=True)
    try:
        method = renderer.method
        assert method.layer_limit == 8
        assert len(method.characters.layers) == 4 and method.max_clumps == 4
        assert any("half the budget" in note for note in method.notes)
        check(renderer, 0.5)
    finally:
        renderer.release()


def test_more_maps_than_the_uniform_block_holds(ctx):
    scene = crowd_scene()
    limits = GLLimits.of(ctx).tightened(max_maps=4)
    settings = ShadowSettings(clump_count=2)
    renderer = Renderer(ctx, scene, SIZE, settings, gbuffer=True, limits=limits)
    try:
        frame = check(renderer)
        assert frame.maps_total <= 4
    finally:
        renderer.release()


def test_small_max_texture_size_and_budget(ctx):
    limits = GLLimits.of(ctx).tightened(max_texture_size=512)
    budget = 2 * layer_bytes(512)
    settings = ShadowSettings(clump_resolution=2048, budget_mib=budget / 2**20)
    renderer = Renderer(ctx, crowd_scene(), SIZE, settings, gbuffer=True, limits=limits)
    try:
        notes = renderer.notes
        assert renderer.settings.clump_resolution == 512
        assert any("GL_MAX_TEXTURE_SIZE" in n for n in notes)
        # The budget holds two 512^2 layers: the clumps and the characters share them.
        assert renderer.shadow_memory_bytes == 0
        check(renderer)
        assert renderer.shadow_memory_bytes <= budget
    finally:
        renderer.release()


def test_capture_clamps_a_resolution_above_the_gl_limit(tmp_path, capsys):
    from tests.cli.cli_helpers import run_here

    result = run_here(capsys, "capture", TINY_PATH, "--size", "32x18", "--clump-resolution",
                      "99999", "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    notes = result.stderr.strip().splitlines()
    assert notes and all(n.startswith("note: ") for n in notes)
    assert "GL_MAX_TEXTURE_SIZE" in notes[0]


def test_clumps_short_of_layers_get_maps_of_half_the_side(ctx):
    """A density target the budget cannot meet: the clump maps are halved once, four times as
    many, the maps are wider than the target's (the clumps or tiles the budget gives), notes
    say so and give the texels per metre held, and the frame still matches Embree. A budget
    that holds the target keeps 2048, with no such note."""
    scene = parse_scene(TINY, TINY_PATH, TINY_PATH.parent)
    layer_mib = 4 * 2048 ** 2 / 2**20
    short = ShadowSettings(texels_per_metre=4000.0, budget_mib=4 * layer_mib,
                           view_resolution=False)  # the fixed maps' side
    renderer = Renderer(ctx, scene, SIZE, short, gbuffer=True)
    try:
        method = renderer.method
        assert method.resolution == 1024
        assert method.maps.density < short.texels_per_metre  # wider than the target's
        assert any("four times as many" in note for note in method.notes)
        # ... and how much wider, in the texels per metre the maps hold.
        held = f"its clump maps hold {method.maps.density:.3g} texels/m (their median), " \
               "where 4000 were asked"
        assert held in method.notes, method.notes
        _, err = render_and_check(renderer, 0.0)
        assert err["shadowed"] >= 100 and err["error"] <= MAX_ERROR, err["error"]
    finally:
        renderer.release()
    renderer = Renderer(ctx, scene, SIZE, dataclasses.replace(short, texels_per_metre=96.0,
                                                              budget_mib=64 * layer_mib))
    try:
        assert renderer.method.resolution == 2048
        assert renderer.method.maps.density == 96.0
        assert not [n for n in renderer.method.notes if "texels/m (their median)" in n]
    finally:
        renderer.release()
