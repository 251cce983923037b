"""The benchmark's charts (matplotlib, PNG and SVG), drawn from the CSV rows of
game/bench/runner.py.

- ``pareto_SCENE``: shadow error against per-frame total ms, one point per run, the Pareto
  front drawn through the runs no other run beats in both;
- ``scaling_triangles`` / ``scaling_characters``: total ms against static triangles (towns with
  16 walkers) and against walkers (the 4 x 4 town, and the 8 x 8 town), methods at defaults;
- ``scaling_shadow``: shadow-map ms against walkers on the 4 x 4 town, with a line
  proportional to the walkers;
- ``lights``: shadow-map ms, frame ms and error against the number of lights (the night town:
  the moon and 0 to 63 street lamps), methods at defaults;
- ``camera_maps``: camera-pass ms against the maps a frame holds (game/bench/chart_camera.py);
- ``maps_per_fragment`` and ``flicker``: per scene, methods at defaults;
- ``stability_FACTOR``: error (and failures) against the factor's value, per method; a factor
  with a single value is drawn as one bar per method.

Every chart names what it compares in its title and its units in the axis labels, and labels at
least two ticks on each axis. A chart whose data has a single x value shows no trend, so it is
skipped (:func:`figures` says which were).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from game.app import outputs
from game.bench.chart_axes import place_labels, plain_log_ticks, pyplot
from game.bench.chart_camera import camera_figure
from game.bench.rows import camera_ms, maps_ms, row_number
from game.bench.runs import COMPARED_GROUPS

if TYPE_CHECKING:
    from matplotlib.figure import Figure

COLOURS = {"clumped": "#d62728", "single": "#1f77b4", "static-dynamic": "#2ca02c",
           "csm": "#9467bd"}
MARKERS = {"clumped": "o", "single": "s", "static-dynamic": "^", "csm": "D"}
ERROR_LABEL = "shadow error vs Embree, % of pixels shadowed by either"
# Stability factors: what the value is, and its unit.
FACTORS = {"elevation": ("light elevation", "degrees"), "scale": ("scene scale", "metres"),
           "overlap": ("walkers overlapping each other and the statics", ""),
           "out-of-bounds": ("walker's distance out of the scene", "metres"),
           "thin": ("caster thickness", "metres"), "raised-floor": ("floor height", "metres"),
           "maps": ("characters, one map each", "")}
# How a point's label shows a parameter (clump counts aside): the label must fit beside the point.
SHORT = {"clumping": "{}", "clump_resolution": "clump res {}",
         "character_resolution": "char res {}", "single_resolution": "{}",
         "character_texels_per_pixel": "{} char texels/px",
         "cascades": "{} cascades", "cascade_lambda": "lambda {}",
         "cascade_resolution": "res {}", "texels_per_metre": "{} texels/m",
         "rerender_static": "rerender"}


class OnePoint(ValueError):
    """The chart's data has a single x value: there is nothing to compare along x."""


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of points no other point beats in both cost and error (lower is better)."""
    front = []
    for i, (c, e) in enumerate(points):
        if not any((c2 <= c and e2 <= e) and (c2 < c or e2 < e)
                   for j, (c2, e2) in enumerate(points) if j != i):
            front.append(i)
    return front


def _ok(row: dict) -> bool:
    return row.get("status") == "ok"


def _default(row: dict) -> bool:
    return row["run"].split("|")[2] == "defaults"


def _label(row: dict) -> str:
    params = row["run"].split("|")[2]
    if params == "defaults":
        return row["method"]
    parts = []
    for item in params.split(","):
        key, _, value = item.partition("=")
        if key == "clump_count":
            parts.append(f"{value} clump" + ("" if value == "1" else "s"))
        elif key == "character_texels_per_pixel" and float(value) == 0:
            parts.append("char maps all at most")
        else:
            parts.append(SHORT[key].format(value) if key in SHORT else item)
    return f"{row['method']} {' '.join(parts)}"


def _size(rows: list[dict]) -> str:
    """The frame sizes of the rows, e.g. ``320x180``."""
    sizes = sorted({f"{r.get('width', '')}x{r.get('height', '')}" for r in rows} - {"x"})
    return ", ".join(sizes) if sizes else "unknown size"


def _need_two(xs) -> None:
    if len({x for x in xs if not (isinstance(x, float) and math.isnan(x))}) < 2:
        raise OnePoint("only one x value, so one point per method and no trend")


def pareto_figure(plt, rows: list[dict], scene: str) -> Figure | None:
    """Error against total ms of every run on ``scene``; None where it has no finished run."""
    pts = [r for r in rows if r["scene"] == scene and _ok(r)
           and math.isfinite(row_number(r, "error"))
           and math.isfinite(row_number(r, "total_ms_median"))]
    if not pts:
        return None
    _need_two(row_number(r, "total_ms_median") for r in pts)
    fig, ax = plt.subplots(figsize=(7, 4.6))
    notes = []
    for r in pts:
        m = r["method"]
        x, y = row_number(r, "total_ms_median"), 100 * row_number(r, "error")
        ax.scatter(x, y, color=COLOURS.get(m, "k"), marker=MARKERS.get(m, "x"),
                   s=70 if _default(r) else 28, edgecolors="k" if _default(r) else "none",
                   zorder=3)
        if _default(r) or len(pts) <= 12:
            notes.append((x, y, _label(r)))
    front = sorted((pts[i] for i in pareto_front(
        [(row_number(r, "total_ms_median"), row_number(r, "error")) for r in pts])),
        key=lambda r: row_number(r, "total_ms_median"))
    ax.step([row_number(r, "total_ms_median") for r in front],
            [100 * row_number(r, "error") for r in front], where="post", color="#444444",
            linewidth=1, linestyle="--", label="Pareto front", zorder=2)
    shown = {r["method"] for r in pts}
    for m, c in COLOURS.items():
        if m in shown:
            ax.scatter([], [], color=c, marker=MARKERS[m], label=m)
    ax.set_xscale("log")
    plain_log_ticks(ax.xaxis)
    ax.set_xlabel("per-frame total, ms (median after warm-up, log scale)")
    ax.set_ylabel(ERROR_LABEL)
    ax.set_title(f"{scene} at {_size(pts)}: shadow error against per-frame cost\n"
                 f"one point per method and parameter set ({len(pts)} runs; large, outlined: "
                 "defaults)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    place_labels(ax, notes)
    return fig


def scaling_figure(plt, rows: list[dict], axis: str) -> Figure | None:
    """Total ms of methods at defaults against static triangles or characters; None where no
    run fits."""
    if axis == "triangles":
        picked = [r for r in rows if r["group"] == "town" and _ok(r) and _default(r)
                  and row_number(r, "characters") == 16]
        key, label = "static_triangles", "static triangles in the town (log scale)"
        what = "static triangles: towns of different sizes, 16 walkers each"
    elif axis == "characters":
        picked = [r for r in rows if r["group"] == "town" and _ok(r) and _default(r)
                  and r["scene"].startswith(("town_4x4", "town_8x8"))]
        key, label = "characters", "walkers in the town (log scale)"
        what = "walkers: 4 x 4 town (solid) and 8 x 8 town (dotted)"
    else:
        return shadow_scaling_figure(plt, rows)
    picked = [r for r in picked if math.isfinite(row_number(r, key))
              and math.isfinite(row_number(r, "total_ms_median"))]
    if not picked:
        return None
    _need_two(row_number(r, key) for r in picked)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    groups: dict[tuple[str, str], list] = defaultdict(list)
    for r in picked:
        town = r["scene"].split("_")[1] if axis == "characters" else ""
        groups[(r["method"], town)].append((row_number(r, key), row_number(r, "total_ms_median")))
    for (m, town), pts in sorted(groups.items()):
        pts.sort()
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=MARKERS.get(m, "x"),
                color=COLOURS.get(m, "k"), linestyle="-" if town in ("", "4x4") else ":",
                label=f"{m} {town}".strip())
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel(label)
    ax.set_ylabel("per-frame total, ms (median, log scale)")
    ax.set_title(f"per-frame cost against {what}\nmethods at defaults, {_size(picked)}",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def shadow_scaling_figure(plt, rows: list[dict]) -> Figure | None:
    """Shadow-map ms per frame against walkers on the 4 x 4 town, every method at defaults and
    clumped with every character map at the most; a line proportional to the walkers beside
    them. None where no run fits."""
    picked = [r for r in rows if r["group"] == "town" and _ok(r)
              and (r["scene"] == "town_4x4" or r["scene"].startswith("town_4x4_c"))
              and (_default(r) or _label(r).endswith("char maps all at most"))
              and math.isfinite(row_number(r, "characters")) and math.isfinite(maps_ms(r))]
    if not picked:
        return None
    _need_two(row_number(r, "characters") for r in picked)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    series: dict[str, list] = defaultdict(list)
    for r in picked:
        series[_label(r)].append((row_number(r, "characters"), maps_ms(r)))
    for name, pts in sorted(series.items()):
        pts.sort()
        method = name.split()[0]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=MARKERS.get(method, "x"),
                color=COLOURS.get(method, "k"), linestyle="-" if name == method else "--",
                label=name)
    if "clumped" in series:
        x0, y0 = min(series["clumped"])
        xs = sorted({p[0] for pts in series.values() for p in pts})
        ax.plot(xs, [y0 * x / x0 for x in xs], color="0.6", linestyle=":", linewidth=1,
                label="proportional to walkers (from clumped's first point)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel("walkers in the 4 x 4 town (log scale)")
    ax.set_ylabel("shadow-map passes per frame, ms (median, log scale)")
    ax.set_title(f"shadow-map cost against walkers, 4 x 4 town\n{_size(picked)}", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def per_scene_bars_figure(plt, rows: list[dict], column: str, ylabel: str, what: str,
                          scale: float = 1.0) -> Figure | None:
    """``column`` (times ``scale``) of the methods at defaults, one group of bars per scene;
    None where no run has it."""
    picked = [r for r in rows if _ok(r) and _default(r) and r["group"] in COMPARED_GROUPS
              and math.isfinite(row_number(r, column))]
    if not picked:
        return None
    scenes = sorted({r["scene"] for r in picked}, key=lambda s: (s != "courtyard", s))
    _need_two(scenes)
    methods = [m for m in COLOURS if any(r["method"] == m for r in picked)]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(scenes)), 4.0))
    width = 0.8 / max(1, len(methods))
    for j, m in enumerate(methods):
        xs, ys = [], []
        for i, s in enumerate(scenes):
            for r in picked:
                if r["scene"] == s and r["method"] == m:
                    xs.append(i + (j - (len(methods) - 1) / 2) * width)
                    ys.append(scale * row_number(r, column))
        ax.bar(xs, ys, width=width, color=COLOURS[m], label=m)
    ax.set_xticks(range(len(scenes)), scenes, rotation=20, fontsize=7)
    ax.set_xlabel("scene")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{what}, per scene\nmethods at defaults, {_size(picked)}", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def stability_figure(plt, rows: list[dict], factor: str) -> Figure | None:
    """Error of every method against the factor's value (failures as crosses above the rest);
    one bar per method where the factor has a single value. None where no run has it."""
    picked = [r for r in rows if r["group"] == "stability" and r["factor"] == factor]
    if not picked:
        return None
    what, unit = FACTORS.get(factor, (factor, ""))
    values = sorted({row_number(r, "value") for r in picked})
    if len(values) == 1:
        return _stability_bars(plt, picked, factor, what, unit, values[0])
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    numeric = factor in ("elevation", "scale")
    pos = {v: (v if numeric else i) for i, v in enumerate(values)}
    top = max([100 * row_number(r, "error") for r in picked
               if math.isfinite(row_number(r, "error"))] + [1])
    for m in COLOURS:
        mine = sorted((r for r in picked if r["method"] == m), key=lambda r: row_number(r, "value"))
        good = [r for r in mine if _ok(r) and math.isfinite(row_number(r, "error"))]
        ax.plot([pos[row_number(r, "value")] for r in good],
                [100 * row_number(r, "error") for r in good],
                marker=MARKERS[m], color=COLOURS[m], label=m)
        bad = [r for r in mine if not _ok(r)]
        if bad:
            ax.scatter([pos[row_number(r, "value")] for r in bad], [1.1 * top] * len(bad),
                       marker="x", color=COLOURS[m], s=80, label=f"{m} failed")
    if factor == "scale":
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
    if not numeric:
        ax.set_xticks(list(pos.values()), [f"{v:g}" for v in values])
    ax.set_xlabel(f"{what}, {unit}" if unit else what)
    if factor == "scale":
        ax.set_xlabel(f"{ax.get_xlabel()} (log scale)")
    ax.set_ylabel(ERROR_LABEL)
    ax.set_title(f"stability, {factor}: shadow error of each method against {what}\n"
                 f"methods at defaults, {_size(picked)}", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def _stability_bars(plt, picked: list[dict], factor: str, what: str, unit: str,
                    value: float) -> Figure:
    methods = [m for m in COLOURS if any(r["method"] == m for r in picked)]
    methods += sorted({r["method"] for r in picked} - set(methods))
    _need_two(methods)
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    heights, notes = [], []
    for m in methods:
        mine = [r for r in picked if r["method"] == m]
        good = [r for r in mine if _ok(r) and math.isfinite(row_number(r, "error"))]
        heights.append(100 * row_number(good[0], "error") if good else 0.0)
        failed = any(not _ok(r) for r in mine)
        notes.append(f"{heights[-1]:.2f}%" if good else "failed" if failed else "not measured")
    bars = ax.bar(range(len(methods)), heights, color=[COLOURS.get(m, "k") for m in methods])
    ax.bar_label(bars, notes, fontsize=7, padding=2)
    # A method run with other parameters than its defaults says which on its tick.
    ticks = [next((_label(r) for r in picked if r["method"] == m), m) for m in methods]
    ax.set_xticks(range(len(methods)), ticks, fontsize=8)
    ax.set_ylim(0, 1.15 * max(heights + [1.0]))
    ax.set_xlabel("method (at its defaults unless named)")
    ax.set_ylabel(ERROR_LABEL)
    ax.set_title(f"stability, {factor}: shadow error of each method\n{what} = {value:g}"
                 f"{' ' + unit if unit else ''}, {_size(picked)}", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def lights_figure(plt, rows: list[dict]) -> Figure | None:
    """Per-frame cost and shadow error against the number of lights on the night town, every
    method at its defaults, and clumped with view-sized maps where the sweep ran them (dashed).
    None where no run fits."""
    view = "view_resolution=True"
    picked = [r for r in rows if r["group"] == "lights" and r["factor"] == "lights" and _ok(r)
              and (_default(r) or r["run"].split("|")[2] == view)
              and math.isfinite(row_number(r, "lights"))]
    if not picked:
        return None
    _need_two(row_number(r, "lights") for r in picked)
    fig, axes = plt.subplots(1, 4, figsize=(16.0, 4.0))
    panels = (("shadow-map passes, ms (median)", maps_ms),
              ("camera pass (cull + shade), ms (median)", camera_ms),
              ("whole frame, ms (median)", lambda r: row_number(r, "total_ms_median")),
              ("shadow error, % (all lights pooled)",
               lambda r: 100.0 * row_number(r, "error")))
    for ax, (ylabel, value) in zip(axes, panels, strict=True):
        series: dict[tuple[str, bool], list] = defaultdict(list)
        for r in picked:
            series[r["method"], not _default(r)].append((row_number(r, "lights"), value(r)))
        for (method, sized), pts in sorted(series.items()):
            pts.sort()
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=MARKERS.get(method, "x"),
                    color=COLOURS.get(method, "k"), linestyle="--" if sized else "-",
                    label=f"{method}, view-sized maps" if sized else method)
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
        ax.set_xlabel("lights: the moon and street lamps (log scale)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[:3]:
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"cost and error against the number of lights, night town\n{_size(picked)}",
                 fontsize=10)
    fig.tight_layout()
    return fig


def figures(rows: list[dict]) -> tuple[list[tuple[str, Figure]], dict[str, str]]:
    """Every chart the rows allow, as (file stem, figure), and the charts skipped, as
    {stem: why}. The caller closes the figures."""
    if not rows:
        return [], {}
    plt = pyplot()
    builders: list[tuple[str, Callable[[], Figure | None]]] = []
    for scene in sorted({r["scene"] for r in rows if r["group"] in COMPARED_GROUPS}):
        builders.append((f"pareto_{scene}", lambda s=scene: pareto_figure(plt, rows, s)))
    for axis in ("triangles", "characters", "shadow"):
        builders.append((f"scaling_{axis}", lambda a=axis: scaling_figure(plt, rows, a)))
    builders.append(("lights", lambda: lights_figure(plt, rows)))
    builders.append(("camera_maps", lambda: camera_figure(plt, rows, COLOURS, MARKERS, _size)))
    builders.append(("maps_per_fragment", lambda: per_scene_bars_figure(
        plt, rows, "maps_per_fragment", "maps read per shaded pixel, count",
        "shadow maps read per shaded pixel")))
    builders.append(("flicker", lambda: per_scene_bars_figure(
        plt, rows, "flicker", "pixel pairs flipping, %\n(where the reference does not)",
        "flicker under a slowly turning camera", scale=100.0)))
    for factor in sorted({r["factor"] for r in rows if r["group"] == "stability"}):
        builders.append((f"stability_{factor}", lambda f=factor: stability_figure(plt, rows, f)))
    built, skipped = [], {}
    for stem, build in builders:
        try:
            fig = build()
        except OnePoint as exc:
            skipped[stem] = f"skipped: {exc}"
            continue
        if fig is not None:
            built.append((stem, fig))
    return built, skipped


def write_all(rows: list[dict], folder: Path,
              log: Callable[[str], None] | None = None) -> list[Path]:
    """Every chart the rows allow; returns the files written. ``log`` hears of skipped charts."""
    built, skipped = figures(rows)
    if not built and not skipped:
        return []
    plt = pyplot()
    folder.mkdir(parents=True, exist_ok=True)
    renderer = f"{rows[-1].get('renderer', '')}, {rows[-1].get('clock', '')} clock"
    out: list[Path] = []
    for stem, fig in built:
        fig.text(0.99, 0.005, renderer, ha="right", va="bottom", fontsize=6, color="#666666")
        fig.tight_layout()
        for fmt in ("png", "svg"):
            path = folder / f"{stem}.{fmt}"
            outputs.write_figure(path, fig, fmt)
            out.append(path)
        plt.close(fig)
    if log is not None:
        for stem, why in skipped.items():
            log(f"charts: {stem} {why}")
    return out
