"""Axes and labels for matplotlib charts: plain numbers on log axes, and point labels placed
clear of each other. The bench charts (game/bench/charts.py) and the soft sweep's
(game/bench/soft_sweep.py) use them."""

from __future__ import annotations

import math


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain(value: float) -> str:
    """A tick value as a plain number: 20, 0.5, 50k, 1M."""
    if abs(value) >= 1e6:
        return f"{value / 1e6:g}M"
    if abs(value) >= 1e4:
        return f"{value / 1e3:g}k"
    return f"{value:g}"


def plain_log_ticks(axis) -> None:
    """Plain numbers on a log axis (20, 50, 100 rather than 2x10^1), at least two of them in view
    even where the axis spans less than a decade."""
    from matplotlib.ticker import FuncFormatter, Locator, LogLocator, MaxNLocator, NullFormatter

    class PlainLogLocator(Locator):
        """1, 2 and 5 per decade; round, evenly spaced values where fewer than three of those
        are in view; decades only over more than three decades."""

        def __call__(self):
            return self.tick_values(*self.axis.get_view_interval())

        def tick_values(self, vmin, vmax):
            lo, hi = sorted((vmin, vmax))
            if lo > 0 and math.log10(hi / lo) > 3:  # decades only, or the labels collide
                return LogLocator(subs=(1.0,)).tick_values(lo, hi)
            ticks = LogLocator(subs=(1.0, 2.0, 5.0)).tick_values(lo, hi)
            if sum(lo <= t <= hi for t in ticks) >= 3:
                return ticks
            fine = MaxNLocator(nbins=6, steps=[1, 2, 5, 10]).tick_values(lo, hi)
            return [t for t in fine if t > 0]

    axis.set_major_locator(PlainLogLocator())
    axis.set_major_formatter(FuncFormatter(lambda v, _pos: _plain(v)))
    axis.set_minor_formatter(NullFormatter())


# Heights (points) tried for a point's label, nearest first.
LABEL_OFFSETS = (3, *(d for k in range(1, 10) for d in (3 - 10 * k, 3 + 10 * k)))


def place_labels(ax, notes: list[tuple[float, float, str]]) -> None:
    """Label points beside them, each moved up or down (with a leader line), or to the other
    side, until it lies inside the axes and clear of the legend, the other points and the labels
    placed before it."""
    from matplotlib.transforms import Bbox

    fig = ax.figure
    fig.canvas.draw()  # fixes the limits the labels are placed against
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    lo, hi = (math.log(v) for v in ax.get_xlim())
    marks = {}
    for x, y, _text in notes:
        px, py = ax.transData.transform((x, y))
        marks[(x, y)] = Bbox.from_extents(px - 6, py - 6, px + 6, py + 6)
    placed = [ax.get_legend().get_window_extent(renderer)] if ax.get_legend() else []
    for x, y, text in sorted(notes, key=lambda n: (-n[1], n[0])):
        # The costliest points' labels go first to their left, where there is room.
        first = math.log(x) > lo + 0.65 * (hi - lo)
        blocked = placed + [b for k, b in marks.items() if k != (x, y)]
        for dy, left in [(dy, side) for dy in LABEL_OFFSETS for side in (first, not first)]:
            label = _note(ax, x, y, text, left, dy)
            box = label.get_window_extent(renderer)
            inside = frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 \
                and box.y1 <= frame.y1
            if inside and not any(box.overlaps(b) for b in blocked):
                break
            label.remove()
        else:  # no free place near the point: beside it after all
            dy, left = 3, first
            label = _note(ax, x, y, text, left, dy)
            box = label.get_window_extent(renderer)
        if dy != 3:  # the text alone decided the overlap; now link it to its point
            label.remove()
            label = _note(ax, x, y, text, left, dy, leader=True)
        label.set_in_layout(False)
        placed.append(box)


def _note(ax, x: float, y: float, text: str, left: bool, dy: float, leader: bool = False):
    return ax.annotate(text, (x, y), fontsize=6, xytext=(-5 if left else 5, dy),
                       textcoords="offset points", ha="right" if left else "left", va="center",
                       arrowprops=dict(arrowstyle="-", linewidth=0.4, color="#888888")
                       if leader else None)
