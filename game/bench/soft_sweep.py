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
The raster methods (game/soft/raster.py) run beside them on the same G-buffer: segment-maps at
every K of ``--maps``, pcss once; the error chart's time axis is each method's whole frame
but the statics' one-off build (``frame_ms``), so a raster method's walkers' maps count.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from game.app import dumps, interrupts, outputs
from game.bench.rows import write_table
from game.bench.soft_charts import write_chart, write_counter_chart, write_rays_chart
from game.errors import GameError
from game.gpu import context
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.scene import load_scene, reference_scene_path
from game.soft.grid import DEFAULT_STRUCTURE, STRUCTURES
from game.soft.methods import LIMITS, RASTER_METHODS, SAMPLED_METHODS
from game.soft.results import COUNTERS
from game.soft.tracer import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE, TraceSettings

SAMPLES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
MAPS = (1, 2, 4, 8, 16, 32, 64)  # segment-maps: the points along the segment it draws maps from
# The analytic reference runs once, beside them; the raster methods on the first structure only
# (they use none).
METHODS = (*SAMPLED_METHODS, *RASTER_METHODS)
__all__ = ["FIELDS", "METHODS", "sweep", "write_chart", "write_counter_chart", "write_rays_chart"]
BRUTE_MAX_SAMPLES = 8     # brute force beyond this takes minutes per point set on llvmpipe
REPEATS = 3               # trace timings: the median of this many runs
REFERENCE_SAMPLES = 1024
FIELDS = ("scene", "structure", "method", "samples", "trace_ms", "build_ms", "rounds",
          "step_budget", "samples_per_dispatch", "truncated", "rmse_analytic", "rmse_embree",
          *COUNTERS, "bytes_total", "rays", "rays_per_s", "embree_ms", "embree_rays",
          "embree_rays_per_s", "trace_over_embree", "frame_ms", "soft_maps_rendered",
          "soft_maps_static_cached", "soft_triangles_to_maps", "soft_triangles_uncached")


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b) ** 2)))


def sweep(ctx, scene, size: tuple[int, int], samples=SAMPLES, methods=SAMPLED_METHODS,
          extra: dict | None = None, log=print, brute_max: int = BRUTE_MAX_SAMPLES,
          structures=(DEFAULT_STRUCTURE,), repeats: int = REPEATS,
          maps=MAPS) -> tuple[list[dict], dict]:
    """Run the sweep on one scene; returns the rows and a header of what was run where.

    ``extra`` holds TraceSettings fields to vary (cells_per_triangle, vc_slots, vc_pool); every
    structure in ``structures`` runs every traced method at every N on the same G-buffer and
    rays. The raster methods run once on that G-buffer: segment-maps at every K of ``maps``,
    pcss at its defaults.
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
            """The last run, and the median ms of the pass and of the frame (all of the
            method's work but the statics' one-off build: grid or maps)."""
            runs = []
            for _ in range(repeats):
                interrupts.check()  # a signal inside GL code is only recorded
                runs.append(renderer.trace(0.0, settings))
            return runs[-1], (float(np.median([r.ms["trace"] for r in runs])),
                              float(np.median([r.ms["total"] - r.ms.get("build_static", 0.0)
                                               for r in runs])))

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
            log(f"{name} {structure:9s} analytic: {ms[0]:9.1f} ms, rmse vs Embree "
                f"{row['rmse_embree']:.6f}, truncated {row['truncated']}")
            rows += _sampled_rows(timed, name, structure, samples, methods, brute_max, extra,
                                  embree, scored, log)
        rows += _raster_rows(timed, name, maps, methods, scored, log)
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
            interrupts.check()
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
            if method not in SAMPLED_METHODS or method == "brute" and n > brute_max:
                continue
            settings = TraceSettings(method=method, samples=n, structure=structure, **extra)
            result, both = timed(settings)
            ms = both[0]
            row = _row(name, structure, method, n, result, both, *scored)
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


def _raster_rows(timed, name: str, maps, methods, scored: tuple, log) -> list[dict]:
    """The raster methods' rows: segment-maps at every K (in ``samples``), pcss once (one
    map); their map passes beside them."""
    rows = []
    runs = [("segment-maps", k) for k in maps] + [("pcss", 1)]
    for method, k in runs:
        if method not in methods:
            continue
        result, both = timed(TraceSettings(method=method, maps=k))
        row = _row(name, "", method, k, result, both, *scored)
        rows.append(row)
        log(f"{name} {method:12s} K={k:4d}: {both[1]:9.1f} ms a frame ({both[0]:.1f} ms "
            f"lookup), rmse {row['rmse_analytic']:.4f} vs analytic, {row['rmse_embree']:.4f} "
            f"vs Embree; maps drawn {row['soft_maps_rendered']}, cached "
            f"{row['soft_maps_static_cached']}")
    return rows


def _row(scene, structure, method, n, result, ms, truth, reference, covered) -> dict:
    """One row; ``ms`` is the median (pass, frame) ms."""
    vis = result.visibility[covered]
    means = result.means()
    maps = {k: result.maps.get(k, "") for k in FIELDS if k.startswith("soft_")}
    return {"scene": scene, "structure": structure, "method": method, "samples": n,
            "trace_ms": round(ms[0], 3), "frame_ms": round(ms[1], 3),
            "build_ms": round(result.ms.get("build", 0.0), 3), **maps,
            "rounds": result.rounds, "step_budget": result.step_budget,
            "samples_per_dispatch": result.samples_per_dispatch, "truncated": result.truncated,
            "rmse_analytic": round(_rmse(vis, truth), 6),
            "rmse_embree": round(_rmse(vis, reference), 6),
            **{k: round(v, 4) for k, v in means.items()},
            "rays": "", "rays_per_s": "", "embree_ms": "", "embree_rays": "",
            "embree_rays_per_s": "", "trace_over_embree": ""}


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
    parser.add_argument("--maps", default=",".join(map(str, MAPS)),
                        help="segment-maps: comma-separated counts K of maps along the segment")
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
        maps = [int(x) for x in args.maps.split(",")]
        structures = args.structures.split(",")
        unknown = (set(args.methods.split(",")) - set(METHODS)
                   or set(structures) - set(STRUCTURES))
        if (w < 1 or h < 1 or min(samples) < 1 or unknown or args.repeats < 1
                or not all(0 < k <= LIMITS["maps"] for k in maps)):
            raise ValueError
    except ValueError:
        print(f"error: --size WxH, --samples N,N,... (each at least 1), --maps K,K,... (each "
              f"1 to {LIMITS['maps']}), --repeats (at least 1), "
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
                                       repeats=args.repeats, maps=maps)
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
