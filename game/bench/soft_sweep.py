"""The soft-shadow sweep: error versus milliseconds for every method and N, Embree beside it.

``python -m game.bench.soft_sweep [SCENE] --size 160x90 --out docs/images`` renders one G-buffer,
traces it with every method for N = 1, 2, 4, ..., 256 samples, and writes ``soft_sweep.csv`` and
``soft_sweep.png`` (error versus ms, log-log). Errors are RMSE over the shaded points against
``analytic`` and against 1024 stratified Embree samples. For every N the same run casts the tracer's
very rays (``game.reference.soft.tracer_samples``) with Embree's any-hit query on the same CPU, so
the GPU-pass-on-llvmpipe to Embree ratio is measured side by side.
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import time
from pathlib import Path

import numpy as np

from game.app import dumps, outputs
from game.bench.charts import plain_log_ticks
from game.errors import GameError
from game.gpu import context
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.scene import load_scene, reference_scene_path
from game.soft.methods import SAMPLED_METHODS
from game.soft.tracer import COUNTERS, RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE, TraceSettings

SAMPLES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
METHODS = SAMPLED_METHODS  # the analytic reference runs once, beside them
BRUTE_MAX_SAMPLES = 8     # brute force beyond this takes minutes per point set on llvmpipe
REPEATS = 3               # trace timings: the median of this many runs
REFERENCE_SAMPLES = 1024
FIELDS = ("method", "samples", "trace_ms", "build_ms", "samples_per_dispatch", "truncated",
          "rmse_analytic", "rmse_embree", *COUNTERS, "embree_ms", "embree_rays",
          "trace_over_embree")


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b) ** 2)))


def sweep(ctx, scene, size: tuple[int, int], samples=SAMPLES, methods=METHODS,
          extra: dict | None = None, log=print,
          brute_max: int = BRUTE_MAX_SAMPLES) -> tuple[list[dict], dict]:
    """Run the sweep; returns the rows and a header of what was run where.

    ``extra`` holds TraceSettings fields to vary (cells_per_triangle, vc_slots, vc_pool).
    """
    extra = dict(extra or {})
    renderer = Renderer(ctx, scene, size, gbuffer=True)
    rows = []
    try:
        frame = renderer.render(0.0, View.from_camera(scene.camera, size))
        g = frame.gbuffer
        covered = np.isfinite(g["position"]).all(axis=-1)
        light = scene.linear_light

        def timed(settings: TraceSettings):
            runs = [renderer.trace(0.0, settings) for _ in range(REPEATS)]
            return runs[-1], float(np.median([r.ms["trace"] for r in runs]))

        exact, exact_ms = timed(TraceSettings(method="analytic", **extra))
        tracer = renderer.soft_tracer
        spec = tracer.grid.spec
        occluder = sr.EmbreeOccluder(dumps.frame_geometry(scene, 0.0).to_geometry())
        normals = g["normal"][covered].astype(np.float64)
        origins = sr.ray_origins(g["position"][covered], normals,
                                 RAY_OFFSET_SCENE * spec.diagonal, RAY_OFFSET_DISTANCE)
        start = time.perf_counter()
        reference = sr.stratified_reference(occluder, origins, normals, light.a, light.b,
                                            REFERENCE_SAMPLES)
        log(f"Embree reference, {REFERENCE_SAMPLES} samples: "
            f"{time.perf_counter() - start:.1f} s")
        truth = exact.visibility[covered]
        rows.append(_row("analytic", 0, exact, exact_ms, truth, reference, covered))
        rows[-1]["rmse_analytic"] = 0.0
        rows_, cols = np.nonzero(covered)
        index = (size[1] - 1 - rows_) * size[0] + cols  # the tracer's point index (GL rows)
        embree_ms = {}
        for n in samples:
            t = sr.tracer_samples(index, n)
            times = []
            for _ in range(REPEATS):
                occluder.seconds, occluder.rays = 0.0, 0
                sr.segment_visibility(occluder, origins, normals, light.a, light.b, t)
                times.append(occluder.seconds * 1e3)
            embree_ms[n] = (float(np.median(times)), occluder.rays)
            for method in methods:
                if method == "brute" and n > brute_max:
                    continue
                result, ms = timed(TraceSettings(method=method, samples=n, **extra))
                row = _row(method, n, result, ms, truth, reference, covered)
                row["embree_ms"] = round(embree_ms[n][0], 3)
                row["embree_rays"] = embree_ms[n][1]
                row["trace_over_embree"] = round(ms / max(embree_ms[n][0], 1e-9), 4)
                rows.append(row)
                log(f"{method:12s} N={n:4d}: {ms:9.1f} ms, rmse {row['rmse_analytic']:.4f}, "
                    f"ray-tri {row['ray_triangle_tests']:.1f}, tri-tri "
                    f"{row['triangle_triangle_tests']:.1f}; Embree {embree_ms[n][0]:.1f} ms")
        header = {**context.describe(ctx), "clock": tracer.timer.clock,
                  "scene": scene.given,
                  "size": list(size), "shaded_points": int(covered.sum()),
                  "grid_dims": [int(x) for x in spec.dims],
                  "cells_per_triangle": tracer.grid.cells_per_triangle, "settings": extra,
                  "repeats": REPEATS, "reference_samples": REFERENCE_SAMPLES}
    finally:
        renderer.release()
    return rows, header


def _row(method, n, result, ms, truth, reference, covered) -> dict:
    vis = result.visibility[covered]
    means = result.means()
    return {"method": method, "samples": n, "trace_ms": round(ms, 3),
            "build_ms": round(result.ms.get("build", 0.0), 3),
            "samples_per_dispatch": result.samples_per_dispatch, "truncated": result.truncated,
            "rmse_analytic": round(_rmse(vis, truth), 6),
            "rmse_embree": round(_rmse(vis, reference), 6),
            **{k: round(v, 4) for k, v in means.items()},
            "embree_ms": "", "embree_rays": "", "trace_over_embree": ""}


def write_csv(path: Path, rows: list[dict]) -> None:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=FIELDS)
    writer.writeheader()
    writer.writerows(rows)
    outputs.write_bytes(path, buf.getvalue().encode())


def write_chart(path: Path, rows: list[dict], header: dict) -> None:
    """Error versus trace ms, log-log, one line per method; Embree's any-hit time beside."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    floor = 1e-4  # an exact zero error cannot be drawn on a log axis
    for method in METHODS:
        pts = [(r["trace_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
               if r["method"] == method]
        if pts:
            ms, err, n = zip(*pts, strict=True)
            ax.plot(ms, err, "o-", label=method)
            for x, y, k in pts:
                if method == "voxel-cache":
                    ax.annotate(f"N={k}", (x, y), fontsize=7, xytext=(3, 3),
                                textcoords="offset points")
    emb = sorted({(r["embree_ms"], max(r["rmse_embree"], floor), r["samples"]) for r in rows
                  if r["method"] == "grid" and r["embree_ms"] != ""})
    if emb:
        ms, err, _ = zip(*emb, strict=True)
        ax.plot(ms, err, "k--", marker="x", label="Embree any-hit, same rays (CPU)")
    for r in rows:
        if r["method"] == "analytic":
            ax.plot([r["trace_ms"]], [max(r["rmse_embree"], floor)], "r*", markersize=12,
                    label="analytic (exact)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel("ms per frame (trace pass; Embree: query time)")
    ax.set_ylabel(f"RMSE vs {header['reference_samples']} stratified Embree samples")
    counts = ", ".join(str(n) for n in sorted({r["samples"] for r in rows if r["samples"]}))
    ax.set_title(f"soft shadows of {Path(header['scene']).name} at {header['size'][0]}x"
                 f"{header['size'][1]}: error against trace time\neach method at N = {counts}; "
                 f"{header['renderer']}, clock {header['clock']}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


COLOURS = {"brute": "#1f77b4", "grid": "#ff7f0e", "tri-cache": "#2ca02c",
           "voxel-cache": "#d62728", "analytic": "#9467bd"}


def write_counter_chart(path: Path, rows: list[dict], header: dict) -> None:
    """The counters per shaded point against N, one line per method: where each method's work
    goes (ray-triangle tests; triangle-versus-light-triangle tests, the price of the cull)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharex=True)
    for ax, key, label in ((axes[0], "ray_triangle_tests", "ray-triangle tests per point"),
                           (axes[1], "triangle_triangle_tests",
                            "triangle-triangle tests per point")):
        for method in METHODS:
            pts = sorted((r["samples"], r[key]) for r in rows
                         if r["method"] == method and r["samples"] > 0)
            if pts and any(v > 0 for _, v in pts):
                n, v = zip(*pts, strict=True)
                # tri-cache and voxel-cache make the same ray tests: draw one hollow and wider.
                hollow = method == "tri-cache"
                ax.plot(n, [max(x, 1e-2) for x in v], "o--" if hollow else "o-",
                        color=COLOURS[method], label=method, markersize=9 if hollow else 5,
                        markerfacecolor="none" if hollow else COLOURS[method])
        grid_one = [r[key] for r in rows if r["method"] == "grid" and r["samples"] == 1]
        if key == "ray_triangle_tests" and grid_one:
            ax.axhline(grid_one[0], color="k", ls=":", lw=1,
                       label="one point-light ray (grid, N=1)")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
        ax.set_xlabel("samples N along the segment")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"soft shadows of {Path(header['scene']).name} at {header['size'][0]}x"
                 f"{header['size'][1]}: work per shaded point against samples, per method\n"
                 f"{header['renderer']}", fontsize=9)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m game.bench.soft_sweep", description=__doc__)
    parser.add_argument("scene", nargs="?",
                        help="scene file (default: the courtyard, assets/courtyard.toml)")
    parser.add_argument("--size", default="160x90", help="WxH of the G-buffer")
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    parser.add_argument("--samples", default=",".join(map(str, SAMPLES)),
                        help="comma-separated sample counts")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--cells-per-triangle", type=float, default=None)
    parser.add_argument("--vc-slots", type=int, default=None)
    parser.add_argument("--vc-pool", type=int, default=None)
    parser.add_argument("--name", default="soft_sweep", help="file name stem")
    parser.add_argument("--brute-max", type=int, default=BRUTE_MAX_SAMPLES,
                        help="largest N for brute force (its time grows with N x triangles)")
    args = parser.parse_args(argv)
    try:
        w, h = (int(x) for x in args.size.lower().split("x"))
        samples = [int(x) for x in args.samples.split(",")]
        unknown = set(args.methods.split(",")) - set(METHODS)
        if w < 1 or h < 1 or min(samples) < 1 or unknown:
            raise ValueError
    except ValueError:
        print(f"error: --size WxH, --samples N,N,... (each at least 1) and --methods from "
              f"{','.join(METHODS)}; got {args.size!r}, {args.samples!r}, {args.methods!r}",
              file=sys.stderr)
        return 2
    try:
        scene = load_scene(Path(args.scene) if args.scene else reference_scene_path())
    except GameError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    ctx = context.create_headless()
    try:
        rows, header = sweep(ctx, scene, (w, h), samples,
                             args.methods.split(","),
                             {k: v for k, v in (("cells_per_triangle", args.cells_per_triangle),
                                                ("vc_slots", args.vc_slots),
                                                ("vc_pool", args.vc_pool)) if v is not None},
                             brute_max=args.brute_max)
    finally:
        ctx.release()
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(args.out / f"{args.name}.csv", rows)
    outputs.write_json(args.out / f"{args.name}.json", {**header, "rows": rows})
    write_chart(args.out / f"{args.name}.png", rows, header)
    write_counter_chart(args.out / f"{args.name}_counters.png", rows, header)
    print(f"wrote {args.out}/{args.name}.csv, .json, .png and _counters.png", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
