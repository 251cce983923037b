"""The window's picture: FXAA softens edges and leaves flat areas alone; the window filters
shadow edges (PCF) by default, captures do not."""

import numpy as np
import pytest

from game.app.window.present import Presenter
from game.app.window.walkaround import PlayOptions
from game.cli.arguments import build_parser, shadow_settings

SIZE = (64, 48)


def edge_image() -> np.ndarray:
    """A dark, slanted half-plane on a light ground: a stair-stepped edge."""
    h, w = SIZE[1], SIZE[0]
    rows, cols = np.mgrid[0:h, 0:w]
    image = np.full((h, w, 4), 220, np.uint8)
    image[cols * 0.37 + 5 > rows] = (30, 40, 50, 255)
    return image


def presented(ctx, antialias: bool) -> np.ndarray:
    source = ctx.texture(SIZE, 4, edge_image().tobytes())
    presenter = Presenter(ctx, antialias)
    try:
        presenter.resize(SIZE)
        presenter.draw(source, presenter.target, SIZE)
        data = presenter.target.read(components=4)
    finally:
        presenter.release()
        source.release()
    return np.frombuffer(data, np.uint8).reshape(SIZE[1], SIZE[0], 4)[..., :3].astype(int)


def test_fxaa_softens_the_edge_and_only_the_edge(ctx):
    image = edge_image()[..., :3].astype(int)
    plain, smooth = presented(ctx, False), presented(ctx, True)
    assert np.array_equal(plain, image)
    changed = np.any(smooth != image, axis=2)
    # Every changed pixel lies next to the edge (a neighbour of the other colour) ...
    dark = image[..., 0] < 100
    near = np.zeros_like(dark)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near |= np.roll(np.roll(dark, dy, 0), dx, 1) != dark
    inner = np.zeros_like(dark)
    inner[2:-2, 2:-2] = True
    assert changed.any()
    assert not np.any(changed & ~near & inner)
    # ... and takes a value between the two sides.
    values = smooth[changed][:, 0]
    assert np.all((values >= 30) & (values <= 220))
    assert np.any((values > 40) & (values < 210))


@pytest.mark.parametrize("command, expected", [("play", True), ("capture", False)])
def test_pcf_is_on_in_the_window_and_off_elsewhere_unless_asked(command, expected):
    parser = build_parser()
    assert shadow_settings(parser.parse_args([command])).pcf is expected
    assert shadow_settings(parser.parse_args([command, "--no-pcf"])).pcf is False
    assert shadow_settings(parser.parse_args([command, "--pcf"])).pcf is True
    assert PlayOptions().settings.pcf is True
