"""The picture of where a method and the reference disagree, drawn over a grey copy of the frame.

Built from the dump's own arrays (no GL, no decoded PNG): the grey is the method's visibility
on the dumped surfaces, so the method's shadows show dark and its errors show where they sit.
Colours are from Okabe and Ito's palette, told apart with any colour vision: orange where the
method lights what the reference shadows, blue where it shadows what the reference lights,
reddish purple where the reference itself changes with the ray offset, and light grey stripes
where the light does not reach (N.L too low, outside a spot's cone, beyond a light's range).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from game.reference.soft_score import OFF_BY

# (name, RGB, what the colour marks): the legend, in the order ``verify`` prints it.
KINDS = (
    ("too_lit", (230, 159, 0), "orange: lit where the reference shadows"),
    ("too_dark", (0, 114, 178), "blue: shadowed where the reference lights"),
    ("offset", (204, 121, 167), "purple: left out, the reference changes with the ray offset"),
    ("reach", (215, 215, 215), "grey stripes: left out, N.L too low or out of the light's reach"),
)
STRIPE_PERIOD = 4   # pixels: every other pair of diagonals is striped, the frame shows between
SKY_GREY, SURFACE_GREY = 0.08, (0.22, 0.40)   # grey levels: sky; a surface shadowed, fully lit


def kind_masks(method: np.ndarray, reference: np.ndarray, considered: np.ndarray,
               offset: np.ndarray, geometry: np.ndarray, tolerance: float | None = None
               ) -> dict[str, np.ndarray]:
    """The (H, W) bool pixels of each kind of :data:`KINDS`.

    With ``tolerance`` None the two are hard visibilities compared at 0.5 (a NaN in ``method``
    reads as shadowed, as in the error); with a number they are soft visibilities, and a pixel
    is too lit or too dark where they differ by more than it.
    """
    with np.errstate(invalid="ignore"):
        if tolerance is None:
            method_lit, reference_lit = method >= 0.5, reference >= 0.5
            too_lit, too_dark = method_lit & ~reference_lit, ~method_lit & reference_lit
        else:
            diff = np.nan_to_num(method.astype(np.float64)) - np.nan_to_num(reference)
            too_lit, too_dark = diff > tolerance, diff < -tolerance
    return {"too_lit": considered & too_lit, "too_dark": considered & too_dark,
            "offset": offset & geometry, "reach": geometry & ~considered & ~offset}


def picture(method: np.ndarray, normal: np.ndarray, masks: dict[str, np.ndarray]) -> np.ndarray:
    """(H, W, 3) uint8: the grey frame with each kind of :func:`kind_masks` in its colour."""
    geometry = np.isfinite(normal).all(axis=-1)
    lit = np.clip(np.nan_to_num(method.astype(np.float64), nan=0.0), 0.0, 1.0)
    # A little of the normal's height, so that faces stay apart where visibility is even.
    up = np.abs(np.nan_to_num(normal[..., 1].astype(np.float64)))
    dark, bright = SURFACE_GREY
    grey = np.where(geometry, dark + (bright - dark) * lit + 0.08 * up, SKY_GREY)
    image = np.repeat((255 * grey)[..., None], 3, axis=-1)
    h, w = grey.shape
    rows, cols = np.mgrid[0:h, 0:w]
    stripes = (rows + cols) % STRIPE_PERIOD < STRIPE_PERIOD // 2
    for name, colour, _ in KINDS:
        where = masks[name] & stripes if name == "reach" else masks[name]
        image[where] = colour
    return image.astype(np.uint8)


def counts(masks: dict[str, np.ndarray]) -> dict[str, int]:
    """How many pixels of each kind."""
    return {name: int(masks[name].sum()) for name, _, _ in KINDS}


# The same colours on a soft picture, where the two are fractions of the light.
SOFT_WORDS = {"too_lit": f"orange: sees more of the light than the reference, by over {OFF_BY}",
              "too_dark": f"blue: sees less of the light than the reference, by over {OFF_BY}",
              "reach": "grey stripes: left out, no soft visibility dumped"}


def legend(pixel_counts: dict[str, Any], soft: bool = False) -> str:
    """The legend with each kind's count, as one line."""
    words = {name: (SOFT_WORDS.get(name, text) if soft else text) for name, _, text in KINDS}
    return "; ".join(f"{words[name]} {pixel_counts[name]}" for name, _, _ in KINDS)
