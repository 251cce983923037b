"""The soft sweep's charts (game/bench/soft_sweep.py): error against milliseconds per frame,
the tracer's counters against N, and rays per second beside Embree's.

Every method of the soft registry has a colour; the traced methods' series run over N, the
raster methods' over the maps they draw (segment-maps' K; pcss draws one).
"""

from __future__ import annotations

from pathlib import Path

from game.app import outputs
from game.bench.chart_axes import plain_log_ticks
from game.soft.methods import RASTER_METHODS, SAMPLED_METHODS

COLOURS = {"brute": "#1f77b4", "grid": "#ff7f0e", "tri-cache": "#2ca02c",
           "voxel-cache": "#d62728", "analytic": "#9467bd", "segment-maps": "#17becf",
           "pcss": "#8c564b"}
assert set(COLOURS) >= {*SAMPLED_METHODS, *RASTER_METHODS, "analytic"}


def _series(rows: list[dict], methods=SAMPLED_METHODS) -> list[tuple[str, str, str, str]]:
    """(method, structure, label, line style) of every series of ``methods`` in ``rows``: one
    per method, or per method and structure when the rows hold several structures."""
    structures = list(dict.fromkeys(r["structure"] for r in rows
                                    if r["method"] in SAMPLED_METHODS)) or [""]
    styles = ("-", "--", ":", "-.")
    return [(m, st, m if len(structures) == 1 else f"{m}, {st}", styles[i % len(styles)])
            for i, st in enumerate(structures) for m in methods]


def _title(header: dict, what: str) -> str:
    return (f"soft shadows of {header['scene_name']} at {header['size'][0]}x"
            f"{header['size'][1]}: {what}\n{header['renderer']}, clock {header['clock']}")


def write_chart(path: Path, rows: list[dict], header: dict) -> None:
    """Error versus trace ms, log-log, one line per method (and structure); Embree's any-hit
    time beside. ``rows`` are one scene's."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    floor = 1e-4  # an exact zero error cannot be drawn on a log axis
    for method, structure, label, style in _series(rows):
        pts = [(r["frame_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
               if r["method"] == method and r["structure"] == structure]
        if pts:
            ms, err, n = zip(*pts, strict=True)
            ax.plot(ms, err, "o" + style, label=label, color=COLOURS[method])
            for x, y, k in pts:
                if method == "voxel-cache" and structure == rows[0]["structure"]:
                    ax.annotate(f"N={k}", (x, y), fontsize=7, xytext=(3, 3),
                                textcoords="offset points")
    _raster_series(ax, rows, floor)
    emb = sorted({(r["embree_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
                  if r["method"] == "grid" and r["embree_ms"] != ""})
    if emb:
        ms, err, _ = zip(*emb, strict=True)
        ax.plot(ms, err, "k--", marker="x", label="Embree any-hit, same rays (CPU)")
    for r in rows:
        if r["method"] == "analytic":
            ax.plot([r["frame_ms"]], [max(r["rmse_embree"], floor)], "*",
                    color=COLOURS["analytic"], markersize=12,
                    label=f"analytic (exact), {r['structure']}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel("ms per frame, the statics' one-off build left out (Embree: query time)")
    ax.set_ylabel(f"RMSE vs {header['reference_samples']} stratified Embree samples")
    counts = ", ".join(str(n) for n in sorted({r["samples"] for r in rows if r["samples"]
                                               and r["method"] in SAMPLED_METHODS}))
    maps = ", ".join(str(r["samples"]) for r in rows if r["method"] == "segment-maps")
    what = f"traced at N = {counts}" + (f"; segment-maps at K = {maps}" if maps else "")
    ax.set_title(_title(header, f"error against time,\n{what}"), fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


def write_counter_chart(path: Path, rows: list[dict], header: dict) -> None:
    """The counters per shaded point against N, one line per method (and structure): where
    each method's work goes (ray-triangle tests; triangle-versus-light-triangle tests, the price
    of the cull) and the bytes it reads (triangles, structure and candidate lists). ``rows`` are
    one scene's."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    panels = (("ray_triangle_tests", "ray-triangle tests per point"),
              ("triangle_triangle_tests", "triangle-triangle tests per point"),
              ("bytes_total", "bytes read per point (triangles, cells, candidates)"))
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4), sharex=True)
    for ax, (key, label) in zip(axes, panels, strict=True):
        for method, structure, name, style in _series(rows):
            pts = sorted((r["samples"], r[key]) for r in rows
                         if r["method"] == method and r["structure"] == structure
                         and r["samples"] > 0)
            if pts and any(v > 0 for _, v in pts):
                n, v = zip(*pts, strict=True)
                # tri-cache and voxel-cache make the same ray tests: draw one hollow and wider.
                hollow = method == "tri-cache"
                ax.plot(n, [max(x, 1e-2) for x in v], ("o" if not hollow else "s") + style,
                        color=COLOURS[method], label=name, markersize=8 if hollow else 5,
                        markerfacecolor="none" if hollow else COLOURS[method])
        grid_one = [r[key] for r in rows if r["method"] == "grid" and r["samples"] == 1
                    and r["structure"] == rows[0]["structure"]]
        if key != "triangle_triangle_tests" and grid_one:
            ax.axhline(grid_one[0], color="k", ls=":", lw=1,
                       label="one point-light ray (grid, N=1)")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
        ax.set_xlabel("samples N along the segment")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(_title(header, "work and memory traffic per shaded point against samples"),
                 fontsize=9)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


def write_rays_chart(path: Path, rows: list[dict], headers: list[dict]) -> None:
    """Rays per second against N, one panel per scene: every sampled method (and structure),
    with Embree's any-hit on the very same rays beside them."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, axes = plt.subplots(1, len(headers), figsize=(6.5 * len(headers), 4.6), sharey=True,
                             squeeze=False)
    for ax, header in zip(axes[0], headers, strict=True):
        mine = [r for r in rows if r["scene"] == header["scene_name"] and r["rays_per_s"] != ""]
        for method, structure, label, style in _series(mine):
            pts = sorted((r["samples"], r["rays_per_s"]) for r in mine
                         if r["method"] == method and r["structure"] == structure)
            if pts:
                n, v = zip(*pts, strict=True)
                ax.plot(n, v, "o" + style, color=COLOURS[method], label=label)
        emb = sorted({(r["samples"], r["embree_rays_per_s"]) for r in mine})
        if emb:
            n, v = zip(*emb, strict=True)
            ax.plot(n, v, "k--", marker="x", label="Embree any-hit, same rays (CPU)")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
        ax.set_xlabel("samples N along the segment")
        ax.set_ylabel("shadow rays per second")
        ax.set_title(f"{header['scene_name']}, {header['size'][0]}x{header['size'][1]}, "
                     f"{header['shaded_points']} points", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(f"soft-shadow rays per second, every method beside Embree on the same rays\n"
                 f"{headers[0]['renderer']}, clock {headers[0]['clock']}", fontsize=9)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


def _raster_series(ax, rows: list[dict], floor: float) -> None:
    """segment-maps over K, each point marked with its K, and pcss's one point."""
    for method in RASTER_METHODS:
        pts = sorted((r["frame_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
                     if r["method"] == method)
        if not pts:
            continue
        ms, err, _ = zip(*pts, strict=True)
        several = len(pts) > 1
        ax.plot(ms, err, "D-" if several else "D", color=COLOURS[method], markersize=6,
                label=f"{method} (raster{', K maps' if several else ''})")
        for x, y, k in pts:
            if several:
                ax.annotate(f"K={k}", (x, y), fontsize=7, xytext=(3, -9),
                            textcoords="offset points", color=COLOURS[method])
