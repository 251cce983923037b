"""The soft-shadow sweep: error, milliseconds and rays per second for every method and N, with
Embree beside them, on one scene or several.

``python -m game.bench.soft_sweep [SCENE] --size 160x90 --out docs/images`` renders one G-buffer,
traces it with every method for N = 1, 2, 4, ..., 256 samples, and writes ``soft_sweep.csv`` and
``soft_sweep.png`` (error versus ms, log-log). Errors are RMSE over the shaded points against
``analytic`` and against 1024 stratified Embree samples. For every N the same run casts the tracer's
very rays (``game.reference.soft.tracer_samples``) with Embree's any-hit query on the same CPU, so
the GPU-pass-on-llvmpipe to Embree ratio is measured side by side, in milliseconds and in rays
per second. ``--scenes`` sweeps several scenes in one run (the courtyard and the real level, say)
and ``--structures`` every acceleration structure; then each scene gets its own charts and
``soft_sweep_rays.png`` sets every method's rays per second beside Embree's, scene by scene.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from game.app import dumps, outputs
from game.bench.chart_axes import plain_log_ticks
from game.bench.rows import write_table
from game.errors import GameError
from game.gpu import context
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.scene import load_scene, reference_scene_path
from game.soft.grid import DEFAULT_STRUCTURE, STRUCTURES
from game.soft.methods import SAMPLED_METHODS
from game.soft.results import COUNTERS
from game.soft.tracer import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE, TraceSettings

SAMPLES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
METHODS = SAMPLED_METHODS  # the analytic reference runs once, beside them
BRUTE_MAX_SAMPLES = 8     # brute force beyond this takes minutes per point set on llvmpipe
REPEATS = 3               # trace timings: the median of this many runs
REFERENCE_SAMPLES = 1024
FIELDS = ("scene", "structure", "method", "samples", "trace_ms", "build_ms", "rounds",
          "step_budget", "samples_per_dispatch", "truncated", "rmse_analytic", "rmse_embree",
          *COUNTERS, "bytes_total", "rays", "rays_per_s", "embree_ms", "embree_rays",
          "embree_rays_per_s", "trace_over_embree")


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b) ** 2)))


def sweep(ctx, scene, size: tuple[int, int], samples=SAMPLES, methods=METHODS,
          extra: dict | None = None, log=print, brute_max: int = BRUTE_MAX_SAMPLES,
          structures=(DEFAULT_STRUCTURE,), repeats: int = REPEATS) -> tuple[list[dict], dict]:
    """Run the sweep on one scene; returns the rows and a header of what was run where.

    ``extra`` holds TraceSettings fields to vary (cells_per_triangle, vc_slots, vc_pool); every
    structure in ``structures`` runs every method at every N on the same G-buffer and rays.
    """
    extra = dict(extra or {})
    renderer = Renderer(ctx, scene, size, gbuffer=True)
    rows = []
    name = Path(scene.given).stem if scene.given else scene.name
    try:
        frame = renderer.render(0.0, View.from_camera(scene.camera, size))
        g = frame.gbuffer
        covered = np.isfinite(g["position"]).all(axis=-1)

        def timed(settings: TraceSettings):
            runs = [renderer.trace(0.0, settings) for _ in range(repeats)]
            return runs[-1], float(np.median([r.ms["trace"] for r in runs]))

        first = structures[0]
        exact, exact_ms = timed(TraceSettings(method="analytic", structure=first, **extra))
        tracer = renderer.soft_tracer
        spec = tracer.grid.spec
        reference, embree = _embree_side(scene, g, covered, spec.diagonal, size, samples,
                                         repeats, name, log)
        truth = exact.visibility[covered]
        scored = (truth, reference, covered)
        structure_info = {}
        for structure in structures:
            result, ms = (exact, exact_ms) if structure == first else timed(
                TraceSettings(method="analytic", structure=structure, **extra))
            row = _row(name, structure, "analytic", 0, result, ms, *scored)
            rows.append(row)
            structure_info[structure] = renderer.soft_tracer.grid.describe()
            log(f"{name} {structure:9s} analytic: {ms:9.1f} ms, rmse vs Embree "
                f"{row['rmse_embree']:.6f}, truncated {row['truncated']}")
            rows += _sampled_rows(timed, name, structure, samples, methods, brute_max, extra,
                                  embree, scored, log)
        header = {**context.describe(ctx), "clock": renderer.soft_tracer.timer.clock,
                  "scene": scene.given, "scene_name": name,
                  "size": list(size), "shaded_points": int(covered.sum()),
                  "grid_dims": [int(x) for x in spec.dims], "structures": structure_info,
                  "cells_per_triangle": tracer.grid.cells_per_triangle, "settings": extra,
                  "repeats": repeats, "reference_samples": REFERENCE_SAMPLES}
    finally:
        renderer.release()
    return rows, header


def _embree_side(scene, g: dict, covered: np.ndarray, diagonal: float, size: tuple[int, int],
                 samples, repeats: int, name: str, log) -> tuple[np.ndarray, dict]:
    """Embree on the G-buffer's points: the stratified reference visibility, and for every N the
    median ms and the rays of the tracer's very rays cast with the any-hit query."""
    light = scene.linear_light
    occluder = sr.EmbreeOccluder(dumps.frame_geometry(scene, 0.0).to_geometry())
    normals = g["normal"][covered].astype(np.float64)
    origins = sr.ray_origins(g["position"][covered], normals,
                             RAY_OFFSET_SCENE * diagonal, RAY_OFFSET_DISTANCE)
    start = time.perf_counter()
    reference = sr.stratified_reference(occluder, origins, normals, light.a, light.b,
                                        REFERENCE_SAMPLES)
    log(f"{name}: Embree reference, {REFERENCE_SAMPLES} samples: "
        f"{time.perf_counter() - start:.1f} s")
    rows_, cols = np.nonzero(covered)
    index = (size[1] - 1 - rows_) * size[0] + cols  # the tracer's point index (GL rows)
    embree = {}
    for n in samples:
        t = sr.tracer_samples(index, n)
        times = []
        for _ in range(repeats):
            occluder.seconds, occluder.rays = 0.0, 0
            sr.segment_visibility(occluder, origins, normals, light.a, light.b, t)
            times.append(occluder.seconds * 1e3)
        embree[n] = (float(np.median(times)), occluder.rays)
    return reference, embree


def _sampled_rows(timed, name: str, structure: str, samples, methods, brute_max: int,
                  extra: dict, embree: dict, scored: tuple, log) -> list[dict]:
    """The rows of every sampled method at every N on one structure, each beside Embree's
    time for the same rays."""
    rows = []
    for n in samples:
        embree_ms, rays = embree[n]
        for method in methods:
            if method == "brute" and n > brute_max:
                continue
            settings = TraceSettings(method=method, samples=n, structure=structure, **extra)
            result, ms = timed(settings)
            row = _row(name, structure, method, n, result, ms, *scored)
            row.update(rays=rays, rays_per_s=round(rays / max(ms, 1e-9) * 1e3, 1),
                       embree_ms=round(embree_ms, 3), embree_rays=rays,
                       embree_rays_per_s=round(rays / max(embree_ms, 1e-9) * 1e3, 1),
                       trace_over_embree=round(ms / max(embree_ms, 1e-9), 4))
            rows.append(row)
            log(f"{name} {structure:9s} {method:12s} N={n:4d}: {ms:9.1f} ms "
                f"({row['rays_per_s'] / 1e6:.3f} M rays/s), rmse "
                f"{row['rmse_analytic']:.4f}, ray-tri {row['ray_triangle_tests']:.1f}, "
                f"tri-tri {row['triangle_triangle_tests']:.1f}, bytes "
                f"{row['bytes_total']:.0f}; Embree {embree_ms:.1f} ms")
    return rows


def _row(scene, structure, method, n, result, ms, truth, reference, covered) -> dict:
    vis = result.visibility[covered]
    means = result.means()
    return {"scene": scene, "structure": structure, "method": method, "samples": n,
            "trace_ms": round(ms, 3), "build_ms": round(result.ms.get("build", 0.0), 3),
            "rounds": result.rounds, "step_budget": result.step_budget,
            "samples_per_dispatch": result.samples_per_dispatch, "truncated": result.truncated,
            "rmse_analytic": round(_rmse(vis, truth), 6),
            "rmse_embree": round(_rmse(vis, reference), 6),
            **{k: round(v, 4) for k, v in means.items()},
            "rays": "", "rays_per_s": "", "embree_ms": "", "embree_rays": "",
            "embree_rays_per_s": "", "trace_over_embree": ""}


def _series(rows: list[dict]) -> list[tuple[str, str, str, str]]:
    """(method, structure, label, line style) of every series in ``rows``: one per method, or
    per method and structure when the rows hold several structures."""
    structures = list(dict.fromkeys(r["structure"] for r in rows))
    styles = ("-", "--", ":", "-.")
    return [(m, st, m if len(structures) == 1 else f"{m}, {st}", styles[i % len(styles)])
            for i, st in enumerate(structures) for m in METHODS]


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
        pts = [(r["trace_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
               if r["method"] == method and r["structure"] == structure]
        if pts:
            ms, err, n = zip(*pts, strict=True)
            ax.plot(ms, err, "o" + style, label=label, color=COLOURS[method])
            for x, y, k in pts:
                if method == "voxel-cache" and structure == rows[0]["structure"]:
                    ax.annotate(f"N={k}", (x, y), fontsize=7, xytext=(3, 3),
                                textcoords="offset points")
    emb = sorted({(r["embree_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
                  if r["method"] == "grid" and r["embree_ms"] != ""})
    if emb:
        ms, err, _ = zip(*emb, strict=True)
        ax.plot(ms, err, "k--", marker="x", label="Embree any-hit, same rays (CPU)")
    for r in rows:
        if r["method"] == "analytic":
            ax.plot([r["trace_ms"]], [max(r["rmse_embree"], floor)], "*",
                    color=COLOURS["analytic"], markersize=12,
                    label=f"analytic (exact), {r['structure']}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel("ms per frame (trace pass; Embree: query time)")
    ax.set_ylabel(f"RMSE vs {header['reference_samples']} stratified Embree samples")
    counts = ", ".join(str(n) for n in sorted({r["samples"] for r in rows if r["samples"]}))
    ax.set_title(_title(header, f"error against trace time, each method at N = {counts}"),
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


COLOURS = {"brute": "#1f77b4", "grid": "#ff7f0e", "tri-cache": "#2ca02c",
           "voxel-cache": "#d62728", "analytic": "#9467bd"}


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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m game.bench.soft_sweep", description=__doc__)
    parser.add_argument("scene", nargs="?",
                        help="scene file (default: the courtyard, assets/courtyard.toml)")
    parser.add_argument("--scenes", default=None,
                        help="comma-separated scene files, swept in one run (instead of SCENE)")
    parser.add_argument("--size", default="160x90", help="WxH of the G-buffer")
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    parser.add_argument("--samples", default=",".join(map(str, SAMPLES)),
                        help="comma-separated sample counts")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--structures", default=DEFAULT_STRUCTURE,
                        help="comma-separated acceleration structures, from "
                             f"{','.join(STRUCTURES)}")
    parser.add_argument("--cells-per-triangle", type=float, default=None)
    parser.add_argument("--vc-slots", type=int, default=None)
    parser.add_argument("--vc-pool", type=int, default=None)
    parser.add_argument("--repeats", type=int, default=REPEATS,
                        help="trace and Embree timings: the median of this many runs")
    parser.add_argument("--name", default="soft_sweep", help="file name stem")
    parser.add_argument("--brute-max", type=int, default=BRUTE_MAX_SAMPLES,
                        help="largest N for brute force (its time grows with N x triangles)")
    args = parser.parse_args(argv)
    try:
        w, h = (int(x) for x in args.size.lower().split("x"))
        samples = [int(x) for x in args.samples.split(",")]
        structures = args.structures.split(",")
        unknown = (set(args.methods.split(",")) - set(METHODS)
                   or set(structures) - set(STRUCTURES))
        if w < 1 or h < 1 or min(samples) < 1 or unknown or args.repeats < 1:
            raise ValueError
    except ValueError:
        print(f"error: --size WxH, --samples N,N,... (each at least 1), --repeats (at least 1), "
              f"--methods from {','.join(METHODS)} and --structures from "
              f"{','.join(STRUCTURES)}; got {args.size!r}, {args.samples!r}, {args.methods!r}, "
              f"{args.structures!r}", file=sys.stderr)
        return 2
    paths = ([Path(p) for p in args.scenes.split(",")] if args.scenes
             else [Path(args.scene) if args.scene else reference_scene_path()])
    try:
        scenes = [load_scene(p) for p in paths]
    except GameError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    extra = {k: v for k, v in (("cells_per_triangle", args.cells_per_triangle),
                               ("vc_slots", args.vc_slots), ("vc_pool", args.vc_pool))
             if v is not None}
    ctx = context.create_headless()
    rows, headers = [], []
    try:
        for scene in scenes:
            scene_rows, header = sweep(ctx, scene, (w, h), samples, args.methods.split(","),
                                       extra, brute_max=args.brute_max, structures=structures,
                                       repeats=args.repeats)
            rows += scene_rows
            headers.append(header)
    finally:
        ctx.release()
    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / f"{args.name}.csv", rows, FIELDS)
    outputs.write_json(args.out / f"{args.name}.json",
                       {**headers[0], "scenes": headers, "rows": rows})
    for header in headers:
        stem = args.name if len(headers) == 1 else f"{args.name}_{header['scene_name']}"
        mine = [r for r in rows if r["scene"] == header["scene_name"]]
        write_chart(args.out / f"{stem}.png", mine, header)
        write_counter_chart(args.out / f"{stem}_counters.png", mine, header)
    write_rays_chart(args.out / f"{args.name}_rays.png", rows, headers)
    print(f"wrote {args.out}/{args.name}.csv, .json and its charts", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
