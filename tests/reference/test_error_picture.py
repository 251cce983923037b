"""The picture of where a method and the reference disagree (game/reference/error_picture.py):
each kind of pixel in its own colour over the grey frame, and the legend's counts."""

from __future__ import annotations

import numpy as np

from game.reference.error_picture import KINDS, counts, kind_masks, legend, picture

COLOURS = {name: colour for name, colour, _ in KINDS}


def frame_of_four() -> dict[str, np.ndarray]:
    """One row of five pixels: right, too lit, too dark, left out by the offset, out of reach;
    and a sixth of sky."""
    method = np.array([[1.0, 1.0, 0.0, 1.0, 0.0, np.nan]], np.float32)
    reference = np.array([[1.0, 0.0, 1.0, 0.0, 1.0, np.nan]], np.float32)
    normal = np.tile(np.array([0.0, 1.0, 0.0], np.float32), (1, 6, 1))
    normal[0, 5] = np.nan
    considered = np.array([[True, True, True, False, False, False]])
    offset = np.array([[False, False, False, True, False, False]])
    return {"method": method, "reference": reference, "normal": normal,
            "considered": considered, "offset": offset,
            "geometry": np.isfinite(normal).all(axis=-1)}


def test_each_kind_gets_its_colour_and_the_rest_stays_grey():
    f = frame_of_four()
    masks = kind_masks(f["method"], f["reference"], f["considered"], f["offset"], f["geometry"])
    assert counts(masks) == {"too_lit": 1, "too_dark": 1, "offset": 1, "reach": 1}
    image = picture(f["method"], f["normal"], masks)
    assert image.shape == (1, 6, 3) and image.dtype == np.uint8
    assert tuple(image[0, 1]) == COLOURS["too_lit"]
    assert tuple(image[0, 2]) == COLOURS["too_dark"]
    assert tuple(image[0, 3]) == COLOURS["offset"]
    # Out of reach: striped, and (0, 4) lies on a stripe.
    assert tuple(image[0, 4]) == COLOURS["reach"]
    for column in (0, 5):   # a right pixel and the sky: grey
        r, g, b = image[0, column]
        assert r == g == b
    assert image[0, 5, 0] < image[0, 0, 0]   # the sky darker than a lit surface


def test_the_colours_are_told_apart_and_none_is_grey():
    colours = [np.array(c, float) for _, c, _ in KINDS[:3]]
    for i, a in enumerate(colours):
        assert np.ptp(a) > 60   # clearly coloured, never a grey of the frame
        for b in colours[i + 1:]:
            assert np.abs(a - b).max() > 100


def test_soft_pixels_are_wrong_beyond_the_tolerance():
    method = np.array([[0.5, 0.75, 0.2]], np.float32)
    reference = np.array([[0.55, 0.5, 0.5]])
    yes = np.ones((1, 3), bool)
    masks = kind_masks(method, reference, yes, ~yes, yes, tolerance=0.1)
    np.testing.assert_array_equal(masks["too_lit"], [[False, True, False]])
    np.testing.assert_array_equal(masks["too_dark"], [[False, False, True]])


def test_the_legend_names_every_colour_with_its_count():
    line = legend({"too_lit": 3, "too_dark": 9, "offset": 2, "reach": 40})
    assert line.startswith("orange: lit where the reference shadows 3; blue: ")
    assert "purple: " in line and line.endswith(" 40")
    assert "more of the light" in legend(dict.fromkeys(COLOURS, 0), soft=True)
