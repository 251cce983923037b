"""The benchmark's charts (matplotlib, PNG and SVG), drawn from the CSV rows of
game/bench/runner.py.

- ``pareto_SCENE``: shadow error against per-frame total ms, one point per run, the Pareto
  front drawn through the runs no other run beats in both;
- ``scaling_triangles`` / ``scaling_characters``: total ms against static triangles (towns with
  16 walkers) and against walkers (the 4 x 4 town, and the 8 x 8 town), methods at defaults;
- ``maps_per_fragment`` and ``flicker``: per scene, methods at defaults;
- ``stability_FACTOR``: error (and failures) against the factor's value, per method.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

from game.app import outputs
from game.bench.rows import row_number

COLOURS = {"clumped": "#d62728", "single": "#1f77b4", "static-dynamic": "#2ca02c",
           "csm": "#9467bd"}
MARKERS = {"clumped": "o", "single": "s", "static-dynamic": "^", "csm": "D"}


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
    return row["method"] if params == "defaults" else f"{row['method']} {params}"


def _figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain_log_ticks(axis) -> None:
    """Plain numbers (20, 50, 100) on a log axis instead of 2x10^1."""
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(ScalarFormatter())
    axis.set_minor_formatter(NullFormatter())


def _save(plt, fig, folder: Path, stem: str, renderer: str) -> list[Path]:
    fig.text(0.99, 0.005, renderer, ha="right", va="bottom", fontsize=6, color="#666666")
    fig.tight_layout()
    paths = []
    for fmt in ("png", "svg"):
        path = folder / f"{stem}.{fmt}"
        outputs.write_figure(path, fig, fmt)
        paths.append(path)
    plt.close(fig)
    return paths


def pareto(plt, rows: list[dict], scene: str, folder: Path, renderer: str) -> list[Path]:

    pts = [r for r in rows if r["scene"] == scene and _ok(r)
           and math.isfinite(row_number(r, "error"))
           and math.isfinite(row_number(r, "total_ms_median"))]
    if not pts:
        return []
    fig, ax = plt.subplots(figsize=(7, 4.6))
    for r in pts:
        m = r["method"]
        x, y = row_number(r, "total_ms_median"), 100 * row_number(r, "error")
        ax.scatter(x, y, color=COLOURS.get(m, "k"), marker=MARKERS.get(m, "x"),
                   s=70 if _default(r) else 28, edgecolors="k" if _default(r) else "none",
                   zorder=3)
        if _default(r) or len(pts) <= 12:
            ax.annotate(_label(r).replace("single_resolution=", "")
                        .replace("cascade_resolution=", "res=")
                        .replace("single_resolution", ""), (x, y), fontsize=6,
                        xytext=(4, 3), textcoords="offset points")
    front = sorted((pts[i] for i in pareto_front(
        [(row_number(r, "total_ms_median"), row_number(r, "error")) for r in pts])),
        key=lambda r: row_number(r, "total_ms_median"))
    ax.step([row_number(r, "total_ms_median") for r in front],
            [100 * row_number(r, "error") for r in front], where="post", color="#444444",
            linewidth=1, linestyle="--", label="Pareto front", zorder=2)
    for m, c in COLOURS.items():
        ax.scatter([], [], color=c, marker=MARKERS[m], label=m)
    ax.set_xscale("log")
    _plain_log_ticks(ax.xaxis)
    ax.set_xlabel("per-frame total, ms (median after warm-up)")
    ax.set_ylabel("shadow error vs Embree, %")
    ax.set_title(f"{scene}: error against cost (large, outlined: defaults)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return _save(plt, fig, folder, f"pareto_{scene}", renderer)


def scaling(plt, rows: list[dict], axis: str, folder: Path, renderer: str) -> list[Path]:
    """Total ms of methods at defaults against static triangles or characters."""
    if axis == "triangles":
        picked = [r for r in rows if r["group"] == "town" and _ok(r) and _default(r)
                  and row_number(r, "characters") == 16]
        key, label = "static_triangles", "static triangles (towns, 16 walkers)"
    else:
        picked = [r for r in rows if r["group"] == "town" and _ok(r) and _default(r)
                  and r["scene"].startswith(("town_4x4", "town_8x8"))]
        key, label = "characters", "walkers (4 x 4 and 8 x 8 towns)"
    if not picked:
        return []
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
    _plain_log_ticks(ax.xaxis)
    _plain_log_ticks(ax.yaxis)
    ax.set_xlabel(label)
    ax.set_ylabel("per-frame total, ms")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return _save(plt, fig, folder, f"scaling_{axis}", renderer)


def per_scene_bars(plt, rows: list[dict], column: str, ylabel: str, stem: str, folder: Path,
                   renderer: str) -> list[Path]:
    picked = [r for r in rows if _ok(r) and _default(r) and r["group"] in ("main", "town")
              and math.isfinite(row_number(r, column))]
    if not picked:
        return []
    scenes = sorted({r["scene"] for r in picked}, key=lambda s: (s != "default", s))
    methods = [m for m in COLOURS if any(r["method"] == m for r in picked)]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(scenes)), 4.0))
    width = 0.8 / max(1, len(methods))
    for j, m in enumerate(methods):
        xs, ys = [], []
        for i, s in enumerate(scenes):
            for r in picked:
                if r["scene"] == s and r["method"] == m:
                    xs.append(i + (j - (len(methods) - 1) / 2) * width)
                    ys.append(row_number(r, column))
        ax.bar(xs, ys, width=width, color=COLOURS[m], label=m)
    ax.set_xticks(range(len(scenes)), scenes, rotation=20, fontsize=7)
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    return _save(plt, fig, folder, stem, renderer)


def stability_chart(plt, rows: list[dict], factor: str, folder: Path, renderer: str
                    ) -> list[Path]:
    picked = [r for r in rows if r["group"] == "stability" and r["factor"] == factor]
    if not picked:
        return []
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    values = sorted({row_number(r, "value") for r in picked})
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
    ax.set_xlabel({"elevation": "light elevation, degrees", "scale": "scene scale, metres",
                   }.get(factor, factor))
    if not numeric:
        ax.set_xticks(list(pos.values()), [f"{v:g}" for v in values])
    ax.set_ylabel("shadow error vs Embree, %")
    ax.set_title(f"stability: {factor}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return _save(plt, fig, folder, f"stability_{factor}", renderer)


def write_all(rows: list[dict], folder: Path) -> list[Path]:
    """Every chart the rows allow; returns the files written."""
    if not rows:
        return []
    plt = _figure()
    folder.mkdir(parents=True, exist_ok=True)
    renderer = f"{rows[-1].get('renderer', '')}, {rows[-1].get('clock', '')} clock"
    out: list[Path] = []
    for scene in sorted({r["scene"] for r in rows if r["group"] in ("main", "town")}):
        out += pareto(plt, rows, scene, folder, renderer)
    out += scaling(plt, rows, "triangles", folder, renderer)
    out += scaling(plt, rows, "characters", folder, renderer)
    out += per_scene_bars(plt, rows, "maps_per_fragment", "maps read per shaded pixel",
                          "maps_per_fragment", folder, renderer)
    out += per_scene_bars(plt, rows, "flicker", "share of pixel pairs flipping\n(where the "
                          "reference does not)", "flicker", folder, renderer)
    for factor in sorted({r["factor"] for r in rows if r["group"] == "stability"}):
        out += stability_chart(plt, rows, factor, folder, renderer)
    return out
