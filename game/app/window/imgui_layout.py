"""Sizes the HUD, the panel and its tabs share: the font's scale with the window, the margin,
and how wide a control is beside its label."""

from __future__ import annotations

import math

from imgui_bundle import imgui

PANEL_MARGIN = 6                   # pixels between the overlay and the window's top-left corner
# The font is scaled with the window, relative to the size the overlay is laid out for.
REFERENCE_SIZE = (960, 540)
FONT_SCALE_RANGE = (0.75, 2.0)
MIN_ITEM_FRACTION = 0.4            # of the panel's row: a control's least width beside its label


def font_scale(size: tuple[int, int]) -> float:
    """The overlay's font scale in a window of ``size``: 1 at :data:`REFERENCE_SIZE`."""
    scale = min(size[0] / REFERENCE_SIZE[0], size[1] / REFERENCE_SIZE[1])
    return min(max(scale, FONT_SCALE_RANGE[0]), FONT_SCALE_RANGE[1])


def font_ratio() -> float:
    """The font's size now over its size at scale 1: pixel sizes grow with it."""
    return imgui.get_font_size() / imgui.get_style().font_size_base


def window_rect() -> tuple[int, int, int, int]:
    """x, y, w, h of the imgui window being built, whole window pixels."""
    pos, extent = imgui.get_window_pos(), imgui.get_window_size()
    return (int(pos.x), int(pos.y), int(math.ceil(extent.x)), int(math.ceil(extent.y)))


def push_item_width(labels) -> None:
    """Controls as wide as the row less the longest label beside them (so that no label runs
    past the panel), but no narrower than :data:`MIN_ITEM_FRACTION` of the row."""
    avail = imgui.get_content_region_avail().x
    label = (max(imgui.calc_text_size(text).x for text in labels)
             + imgui.get_style().item_inner_spacing.x)
    # Negative: up to that far from the row's right edge, also after a checkbox on the row.
    imgui.push_item_width(-label if avail - label >= MIN_ITEM_FRACTION * avail
                          else MIN_ITEM_FRACTION * avail)
