"""The overlay's strip along the bottom of the window: the collapse notes of the frame
(game/shadows/collapse.py), drawn under the HUD, and nothing where the shadows hold."""

from __future__ import annotations

import numpy as np
import pytest

from game.render.renderer import Renderer, View
from game.shadows.plan import ShadowSettings

SIZE = (640, 360)
BAND = 40  # pixels at the bottom of the frame, where the strip lies


@pytest.mark.parametrize(("budget_mib", "collapsed"), [(0.25, True), (512.0, False)])
def test_strip_shows_collapse_notes(ctx, courtyard, budget_mib, collapsed):
    from game.app.window.overlay import Overlay

    renderer = Renderer(ctx, courtyard, SIZE, ShadowSettings(budget_mib=budget_mib))
    overlay = Overlay(panel=False)
    try:
        frame = renderer.render(0.0, View.from_camera(courtyard.camera, SIZE))
        picture = frame.image.copy()
        drawn = overlay.draw_over_frame(renderer, frame, 1 / 30)
        notes = renderer.collapse_notes()
        assert bool(notes) == collapsed
        assert overlay.warnings == tuple(f"note: {n}" for n in notes)
        changed = np.any(drawn[-BAND:] != picture[-BAND:])
        assert changed == collapsed
    finally:
        overlay.release()
        renderer.release()
