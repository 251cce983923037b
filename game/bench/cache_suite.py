"""``python -m game bench --suite cache``: do the cached methods spare the CPU's caches?

"Some Ideas on Shadow Algorithms" expects the per-voxel candidate lists (``voxel-cache``) to keep
a point's working set small enough for high first-level cache hit rates, where the per-triangle
words (``tri-cache``) save arithmetic but not memory traffic. llvmpipe's timings cannot show
that, so the suite measures it on the CPU twin of the tracer (game/soft/cpu_twin.py), which
casts the GPU pass's very rays through the very same arrays:

- simulated data-cache misses per ray and per shaded point, first level and last level, and the
  data references (game/bench/cache_grind.py says how the twin's own accesses are isolated);
- native milliseconds per ray of the twin, one thread per core (``threads`` column) and on one
  thread (Embree's query below traces its rays one by one on one thread), the fastest of the
  repeats, beside
  Embree's any-hit query on the same rays (game/reference/soft.py);
- the GPU pass on the same G-buffer: how many points' visibility the twin matches, and the
  shader's counters, beside the twin's own.

It writes ``OUT/cache.csv``, ``OUT/cache.png`` (misses per ray against N, one panel row per
scene) and ``OUT/run.json``.
"""

from __future__ import annotations

import os
import platform
import tempfile
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from game.app import dumps, outputs
from game.bench import cache_grind
from game.bench.rows import write_table
from game.bench.runner import git_commit
from game.data import CHECKOUT_DIR
from game.errors import GameError
from game.gpu import context
from game.reference import soft as sr
from game.scene import load_scene
from game.soft import cpu_twin
from game.soft.grid import DEFAULT_STRUCTURE
from game.soft.methods import TraceSettings
from game.soft.tracer import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE

SCENES = ("assets/courtyard.toml", "assets/real/monastery.toml")
QUICK_SCENES = ("assets/courtyard.toml",)
SAMPLES = (1, 8, 32, 256)
QUICK_SAMPLES = (1, 8)
SIZE = (80, 45)
QUICK_SIZE = (32, 18)
METHODS = ("grid", "tri-cache", "voxel-cache", "brute")
BRUTE_MAX_SAMPLES = 1
# brute under the cache simulator only where its ray-triangle tests stay below this (about a
# minute): on the monastery one sample per point is already 3e8 tests.
GRIND_MAX_BRUTE_TESTS = 3e7
REPEATS = 3
MIN_TIMING_S = 0.5     # each timing repeats its run for at least this long
THREADS = os.cpu_count() or 1  # the twin's native timing: one thread per core
COUNTERS = ("ray_triangle_tests", "triangle_triangle_tests", "voxels_visited", "candidates",
            "overflows", "bytes_triangles", "bytes_cells", "bytes_candidates")
FIELDS = ("scene", "structure", "method", "samples", "points", "rays", "threads",
          "d1_misses_per_ray", "ll_misses_per_ray", "d_refs_per_ray", "instructions_per_ray",
          "d1_misses_per_point", "ll_misses_per_point", "d_refs_per_point", "ms_per_ray",
          "ms_per_ray_1thread", "embree_ms_per_ray", "cpu_over_embree", "gpu_equal",
          "gpu_differ", "grind_equal",
          *(f"twin_{c}" for c in COUNTERS), "twin_bytes_total",
          *(f"gpu_{c}" for c in COUNTERS), "gpu_bytes_total", "gpu_dispatches", "gpu_trace_ms")


@dataclass
class CacheSuite:
    out: Path
    quick: bool = False
    scenes: tuple[str, ...] | None = None
    samples: tuple[int, ...] | None = None
    size: tuple[int, int] | None = None
    structure: str = DEFAULT_STRUCTURE
    repeats: int = REPEATS
    log: object = print
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.scenes = self.scenes or (QUICK_SCENES if self.quick else SCENES)
        self.samples = self.samples or (QUICK_SAMPLES if self.quick else SAMPLES)
        self.size = self.size or (QUICK_SIZE if self.quick else SIZE)


def check_tools() -> None:
    """GameError, one line, where numba or valgrind is missing."""
    if not cpu_twin.numba_available():
        raise GameError(cpu_twin.NUMBA_HINT)
    reason = cache_grind.missing_tools()
    if reason:
        raise GameError(f"the cache suite needs valgrind: {reason}")


def run(suite: CacheSuite, command: str = "") -> dict:
    """Every scene of the suite; writes the csv, the chart and run.json. Returns a summary."""
    check_tools()
    start = time.perf_counter()
    paths = []
    for scene in suite.scenes:
        path = Path(scene)
        if not path.is_file() and not path.is_absolute() and (CHECKOUT_DIR / path).is_file():
            path = CHECKOUT_DIR / path  # the suite's own scenes, from any working directory
        if path.is_file():
            paths.append(path)
        elif path.as_posix().startswith("assets/real/") or "real" in path.parts:
            suite.notes.append(f"skipped {scene}: absent (python assets/fetch_real.py fetches it)")
            suite.log(f"note: {suite.notes[-1]}")
        else:
            raise GameError(f"no scene file {scene}")
    if not paths:
        raise GameError("no scene to measure: " + "; ".join(suite.notes))
    ctx = context.create_headless()
    rows = []
    try:
        gl = context.describe(ctx)
        for path in paths:
            rows += scene_rows(ctx, load_scene(path), suite)
    finally:
        ctx.release()
    suite.out.mkdir(parents=True, exist_ok=True)
    write_table(suite.out / "cache.csv", rows, FIELDS)
    write_chart(suite.out / "cache.png", rows, suite)
    wall = round(time.perf_counter() - start, 1)
    write_record(suite, command, gl, wall)
    return {"rows": len(rows), "csv": str(suite.out / "cache.csv"), "wall_s": wall,
            "notes": suite.notes}


def write_record(suite: CacheSuite, command: str, gl: dict, wall: float) -> None:
    import numba

    record = {"command": command, "renderer": gl["renderer"], "version": gl["version"],
              "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
              "machine": {"cpu": _cpu_name(), "platform": platform.platform(),
                          "python": platform.python_version(), "numba": numba.__version__,
                          "cores": os.cpu_count(), "twin_threads": THREADS},
              "cache_simulation": cache_grind.cache_config(), "size": list(suite.size),
              "structure": suite.structure, "samples": list(suite.samples),
              "notes": suite.notes, "wall_s": wall, **git_commit(suite.out)}
    outputs.write_json(suite.out / "run.json", record)


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _jobs(suite: CacheSuite) -> list[tuple[str, int]]:
    return [(m, n) for n in suite.samples for m in METHODS
            if m != "brute" or n <= BRUTE_MAX_SAMPLES]


def scene_rows(ctx, scene, suite: CacheSuite) -> list[dict]:
    """The suite's rows of one scene: GPU pass, twin, Embree and the cache simulation."""
    from game.render.renderer import Renderer, View

    name = Path(scene.given).stem if scene.given else scene.name
    if scene.linear_light is None:
        raise GameError(f"{name} has no [linear_light] to trace")
    renderer = Renderer(ctx, scene, suite.size, gbuffer=True)
    try:
        frame = renderer.render(0.0, View.from_camera(scene.camera, suite.size))
        points, covered = cpu_twin.TwinPoints.from_gbuffer(frame.gbuffer)
        gpu = {}
        for method, n in _jobs(suite):
            settings = TraceSettings(method=method, samples=n, structure=suite.structure)
            gpu[(method, n)] = renderer.trace(0.0, settings)
            suite.log(f"{name} GPU {method} N={n}: {gpu[(method, n)].ms['trace']:.0f} ms")
        twin_scene = cpu_twin.TwinScene.from_tracer(renderer.soft_tracer,
                                                    renderer.traced.segment())
        embree = _embree(scene, frame.gbuffer, covered, renderer.soft_tracer.grid.spec.diagonal,
                         points, suite)
    finally:
        renderer.release()
    rows = [_twin_row(name, twin_scene, points, covered, method, n, gpu[(method, n)],
                      embree[n], suite) for method, n in _jobs(suite)]
    _add_grind(rows, name, twin_scene, points, suite)
    return rows


def _embree(scene, gbuffer: dict, covered: np.ndarray, diagonal: float,
            points: cpu_twin.TwinPoints, suite: CacheSuite) -> dict[int, float]:
    """Embree's any-hit ms per ray on the tracer's rays, for every N (the fastest repeat)."""
    light = scene.linear_light
    occluder = sr.EmbreeOccluder(dumps.frame_geometry(scene, 0.0).to_geometry())
    normals = gbuffer["normal"][covered].astype(np.float64)
    origins = sr.ray_origins(gbuffer["position"][covered], normals,
                             RAY_OFFSET_SCENE * diagonal, RAY_OFFSET_DISTANCE)
    out = {}
    for n in suite.samples:
        t = sr.tracer_samples(points.index.astype(np.uint32), n)

        def once(t=t):
            occluder.seconds, occluder.rays = 0.0, 0
            sr.segment_visibility(occluder, origins, normals, light.a, light.b, t)
            return occluder.seconds / max(1, occluder.rays)

        out[n] = _fastest(once, suite.repeats) * 1e3
    return out


def _fastest(timed, repeats: int) -> float:
    """The fastest of at least ``repeats`` runs of ``timed`` (which returns its seconds), and of
    as many more as fit in MIN_TIMING_S: on a shared machine the noise only ever adds time."""
    timed()  # warm: compiled, cached, paged in
    times, start = [], time.perf_counter()
    while len(times) < repeats or time.perf_counter() - start < MIN_TIMING_S:
        times.append(timed())
    return min(times)


def _twin_row(name, twin_scene, points, covered, method, n, gpu_result, embree_ms, suite):
    """The twin against the GPU pass: equality and counters, and its native ms per ray."""
    counted = cpu_twin.trace(twin_scene, points, method, n, threads=None, count=True)
    same = counted.visibility == gpu_result.visibility[covered]
    threads = THREADS
    rays = int(counted.rays.sum())
    ms = {k: _fastest(lambda k=k: cpu_twin.trace(twin_scene, points, method, n, threads=k,
                                                 count=False).seconds, suite.repeats)
          * 1e3 / max(1, rays) for k in {1, threads}}
    ms_per_ray = ms[threads]
    p = len(points)
    twin = {f"twin_{c}": round(float(counted.counters[c].sum()) / p, 3) for c in COUNTERS}
    twin["twin_bytes_total"] = round(sum(twin[f"twin_{c}"] for c in COUNTERS
                                         if c.startswith("bytes")), 1)
    means = gpu_result.means()
    gpu_cols = {f"gpu_{c}": round(means[c], 3) for c in COUNTERS}
    suite.log(f"{name} twin {method} N={n}: {int(same.sum())}/{p} points equal the GPU's, "
              f"{ms_per_ray * 1e6:.0f} ns per ray on {threads} threads, Embree "
              f"{embree_ms * 1e6:.0f} ns")
    return {"scene": name, "structure": suite.structure, "method": method, "samples": n,
            "points": p, "rays": rays, "threads": threads, "ms_per_ray": round(ms_per_ray, 7),
            "ms_per_ray_1thread": round(ms[1], 7),
            "embree_ms_per_ray": round(embree_ms, 7),
            "cpu_over_embree": round(ms[1] / max(embree_ms, 1e-12), 3),  # both on one thread
            "gpu_equal": int(same.sum()), "gpu_differ": int((~same).sum()), **twin, **gpu_cols,
            "gpu_bytes_total": round(means["bytes_total"], 1),
            "gpu_dispatches": round(means["dispatches"], 3),
            "gpu_trace_ms": round(gpu_result.ms["trace"], 2),
            "_visible": counted.visible}


def _add_grind(rows: list[dict], name: str, twin_scene, points, suite: CacheSuite) -> None:
    """The cache simulation's columns, for every row it can afford."""
    jobs = [(r["method"], r["samples"]) for r in rows
            if r["method"] != "brute"
            or twin_scene.n_triangles * r["rays"] <= GRIND_MAX_BRUTE_TESTS]
    skipped = [f"{r['method']} N={r['samples']}" for r in rows
               if (r["method"], r["samples"]) not in jobs]
    if skipped:
        suite.notes.append(f"{name}: not simulated (too slow under valgrind): "
                           f"{', '.join(skipped)}")
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="cache_grind_") as work:
        grind = cache_grind.simulate(twin_scene, points, jobs, Path(work))
    suite.log(f"{name}: cache simulation of {len(jobs)} runs in "
              f"{time.perf_counter() - start:.0f} s")
    for row in rows:
        visible = row.pop("_visible")
        g = grind.get((row["method"], row["samples"]))
        if g is None:
            row.update({k: "" for k in FIELDS if k not in row})
            continue
        d1 = g["D1mr"] + g["D1mw"]
        ll = g["DLmr"] + g["DLmw"]
        refs = g["Dr"] + g["Dw"]
        rays, p = max(1, row["rays"]), max(1, row["points"])
        row.update(d1_misses_per_ray=round(d1 / rays, 4), ll_misses_per_ray=round(ll / rays, 4),
                   d_refs_per_ray=round(refs / rays, 2),
                   instructions_per_ray=round(g["Ir"] / rays, 1),
                   d1_misses_per_point=round(d1 / p, 3), ll_misses_per_point=round(ll / p, 3),
                   d_refs_per_point=round(refs / p, 1),
                   grind_equal=int((g["visible"] == visible).sum()))


def write_chart(path: Path, rows: list[dict], suite: CacheSuite) -> None:
    """Per scene (a row of panels): first-level and last-level data-cache misses per ray, and
    native ms per ray beside Embree's, against N, one line per method."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    from game.bench.chart_axes import plain_log_ticks
    from game.bench.soft_charts import COLOURS

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    panels = (("d1_misses_per_ray", "L1 data misses per ray (simulated)"),
              ("ll_misses_per_ray", "last-level data misses per ray (simulated)"),
              ("ms_per_ray", "CPU ms per ray (native)"))
    fig, axes = plt.subplots(len(scenes), 3, figsize=(14, 4.2 * len(scenes)), squeeze=False)
    for row_axes, scene in zip(axes, scenes, strict=True):
        mine = [r for r in rows if r["scene"] == scene]
        for ax, (key, label) in zip(row_axes, panels, strict=True):
            # brute's one point (N = 1) would squash the others' time axis; it is in the csv.
            shown = METHODS if key != "ms_per_ray" else METHODS[:3]
            for method in shown:
                pts = sorted((r["samples"], r[key]) for r in mine
                             if r["method"] == method and r[key] != "")
                if pts:
                    n, v = zip(*pts, strict=True)
                    ax.plot(n, [max(x, 1e-4) for x in v], "o-", color=COLOURS[method],
                            label=method if key != "ms_per_ray" else
                            f"{method}, {mine[0]['threads']} threads")
            if key == "ms_per_ray":
                _time_lines(ax, mine, shown, COLOURS)
            ax.set_xscale("log", base=2)
            ax.set_xticks(sorted({r["samples"] for r in mine}))
            ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
            ax.set_yscale("log")
            plain_log_ticks(ax.yaxis)
            ax.set_xlabel("samples N along the segment")
            ax.set_ylabel(label)
            ax.set_title(f"{scene}, {mine[0]['points']} points, {mine[0]['structure']}",
                         fontsize=9)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    d1, ll = cache_grind.D1, cache_grind.LL
    mine = rows
    fig.suptitle(f"the CPU twin of the soft-shadow tracer at {suite.size[0]}x{suite.size[1]}: "
                 f"cachegrind's simulator, L1 {d1[0] // 1024} KiB {d1[1]}-way, last level "
                 f"{ll[0] // 1024} KiB {ll[1]}-way, cold per frame; native ms on "
                 f"{mine[0]['threads']} threads and on 1 (dotted)", fontsize=9)
    fig.tight_layout()
    outputs.write_figure(path, fig)
    plt.close(fig)


def _time_lines(ax, rows: list[dict], methods, colours) -> None:
    """The twin's one-thread ms per ray (dotted) and Embree's, on the same rays."""
    for method in methods:
        pts = sorted((r["samples"], r["ms_per_ray_1thread"]) for r in rows
                     if r["method"] == method)
        if pts:
            n, v = zip(*pts, strict=True)
            ax.plot(n, v, "o:", color=colours[method], markerfacecolor="none",
                    label=f"{method}, 1 thread")
    emb = sorted({(r["samples"], r["embree_ms_per_ray"]) for r in rows})
    n, v = zip(*emb, strict=True)
    ax.plot(n, v, "k--", marker="x", label="Embree any-hit, same rays, 1 thread")
