"""The chart of what the shading pass pays for many maps: a method's camera pass (culling and
shading) over one map's (``single``) on the same scene, against the shadow maps its frame
holds, one point per scene, methods at defaults.

A method whose fragments walked every map would climb with the count; one that finds a
fragment's maps in one fetch stays flat, and the map passes it saves are then a net gain.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from game.bench.rows import camera_ms, row_number
from game.bench.runs import COMPARED_GROUPS

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def camera_figure(plt, rows: list[dict], colours: dict[str, str], markers: dict[str, str],
                  size_of) -> Figure | None:
    """Per scene, each method's camera pass over ``single``'s on the same scene and size,
    against the maps its frame holds, methods at defaults; None where no scene has both."""
    picked = [r for r in rows if r.get("status") == "ok" and r["group"] in COMPARED_GROUPS
              and r["run"].split("|")[2] == "defaults"
              and math.isfinite(row_number(r, "maps_total")) and math.isfinite(camera_ms(r))]
    single = {(r["scene"], r["width"], r["height"]): camera_ms(r) for r in picked
              if r["method"] == "single"}
    picked = [r for r in picked if r["method"] != "single"
              and single.get((r["scene"], r["width"], r["height"]), 0.0) > 0.0]
    if not picked:
        return None
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for method in [m for m in colours if any(r["method"] == m for r in picked)]:
        mine = [r for r in picked if r["method"] == method]
        xs = [max(row_number(r, "maps_total"), 1.0) for r in mine]
        ys = [camera_ms(r) / single[(r["scene"], r["width"], r["height"])] for r in mine]
        ax.scatter(xs, ys, color=colours[method], marker=markers.get(method, "o"), s=28,
                   label=method)
        for x, y, r in zip(xs, ys, mine, strict=True):
            ax.annotate(r["scene"], (x, y), fontsize=6, xytext=(3, 2),
                        textcoords="offset points")
    ax.axhline(1.0, color="#1f77b4", lw=1.0, ls="--", label="single (one map)")
    ax.set_xscale("log")
    ax.set_xlabel("shadow maps in the frame, count (log)")
    ax.set_ylabel("camera pass (cull + shade),\nover single's on the same scene")
    ax.set_title("what the shading pass pays for many maps\nmethods at defaults, "
                 f"{size_of(picked)}", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return fig
