"""The speed-versus-accuracy benchmark: methods x parameters x scenes along a fixed camera path.

Each run renders one scene with one method and one parameter set and writes one CSV row:

- timing frames (no G-buffer): the camera orbits the scene camera's target by ``ORBIT_DEG``
  per frame while the characters walk at 30 frames per scene second; per pass, the median and
  p95 over the frames after the warm-up; maps and triangles and texels drawn into maps per frame;
  shadow memory; maps read per shaded pixel;
- error frames (G-buffer dumps, CONTRACT.md section 3): written to disk and scored by the
  independent Embree reference (game/reference.py), which reads only the dump files;
- flicker frames: scene time frozen, only the camera moves (``FLICKER_DEG`` per frame); a pixel
  flickers when the surface point it sees was lit in one frame and shadowed in the next while
  the reference's verdict on the same two samples did not change (``flicker_rates``).

The CSV is rewritten atomically after every run (game/outputs.py): an interrupted bench keeps
every finished row, and a rerun skips the rows it already has. Charts: game/charts.py.
"""

from __future__ import annotations

import csv
import io
import math
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from game import transforms
from game.app import dumps, interrupts, outputs
from game.bench import charts, stability
from game.bench.charts import row_number
from game.errors import GameError
from game.gpu import context
from game.reference import hard as reference
from game.reference.score import score_dump
from game.render.renderer import Renderer, View
from game.scene import Scene, default_scene_path, floors, parse_scene
from game.shadows import registry
from game.shadows.plan import MapRecord, ShadowSettings

FPS = 30.0                  # scene seconds per timing frame: 1 / FPS
ORBIT_DEG = 1.0             # camera yaw per timing frame about the scene camera's target
FLICKER_DEG = 0.25          # camera yaw per flicker frame (time frozen)
ERROR_SPACING_S = 0.75      # scene seconds between error frames (characters move between them)
PASSES = ("shadow_static", "shadow_dynamic", "cull", "shade", "total")
PARAM_KEYS = ("clumping", "clump_count", "texels_per_metre", "clump_resolution",
              "character_resolution", "single_resolution", "cascades", "cascade_lambda",
              "cascade_resolution")
# Bench-only parameter: re-render every cached map every frame, to measure the cost of many
# small maps (framebuffer and layer switches, clears) against one map at equal triangles.
RERENDER = "rerender_static"
# (clump count, clump map resolution) of that experiment: the same statics and the same texels
# (4096^2) in 1 to 64 maps, so what grows with the count is the per-map cost.
SWITCH_SERIES = ((1, 4096), (4, 2048), (16, 1024), (64, 512))
COLUMNS = (
    ["run", "scene", "group", "factor", "value", "method", *PARAM_KEYS, RERENDER, "width",
     "height",
     "frames", "warmup", "renderer", "version", "clock", "static_triangles", "characters"]
    + [f"{p}_ms_{stat}" for p in PASSES for stat in ("median", "p95", "min")]
    + ["repeats", "total_ms_spread"]
    + ["maps_total", "maps_rendered", "triangles_to_maps", "texels_to_maps",
       "camera_triangles", "shadow_memory_mib", "maps_per_fragment", "static_maps",
       "footprint_overlap", "static_texels_per_metre", "error", "misclassified", "shadowed",
       "error_frames", "flicker", "flicker_raw", "flicker_reference", "nan_pixels", "notes",
       "status", "seconds"]
)


@dataclass(frozen=True)
class BenchScene:
    """One scene of the sweep."""

    key: str
    group: str               # main | town | stability
    text: str                # the scene file's text (written to OUT/scenes/KEY.toml)
    factor: str = ""         # stability factor, or the scaling axis of a town
    value: float = 0.0
    accuracy_expected: bool = True


@dataclass(frozen=True)
class RunSpec:
    scene: str
    method: str
    params: tuple[tuple[str, object], ...] = ()

    def settings(self) -> ShadowSettings:
        params = {k: v for k, v in self.params if k != RERENDER}
        return ShadowSettings(method=self.method, **params)

    @property
    def rerender(self) -> bool:
        return bool(dict(self.params).get(RERENDER, False))

    def run_id(self, size: tuple[int, int]) -> str:
        p = ",".join(f"{k}={v}" for k, v in self.params) or "defaults"
        return f"{self.scene}|{self.method}|{p}|{size[0]}x{size[1]}"


@dataclass
class BenchOptions:
    out: Path
    quick: bool = False
    size: tuple[int, int] = (320, 180)
    frames: int = 8
    warmup: int = 2
    error_frames: int = 2
    flicker_frames: int = 3
    repeat: int = 1                      # timings per run, interleaved within a scene
    scenes: list[str] | None = None      # only these scene keys (fnmatch patterns)
    methods: list[str] | None = None
    reference: bool = True
    progress: bool = True
    log: Callable[[str], None] = field(default=lambda line: print(line, file=sys.stderr))


# -- the sweep ------------------------------------------------------------------------------
def town_text(blocks: int, characters: int, name: str) -> str:
    """A town like assets/town_1m.toml with ``blocks`` per side; the camera keeps its framing."""
    span = blocks * 50.0 + 10.0
    k = span / 410.0
    return f"""name = "{name}"

[camera]
position = [0.0, {190.0 * k:.4g}, {330.0 * k:.4g}]
target   = [0.0, 0.0, {20.0 * k:.4g}]
fov      = 55.0
near     = {max(0.1, 1.0 * k):.4g}
far      = {1000.0 * k:.4g}

[light]
kind      = "directional"
direction = [-0.4, -1.0, -0.3]

[generate]
seed                = 1
blocks              = {blocks}
block_size          = 40.0
street_width        = 10.0
buildings_per_block = 4
trees_per_block     = 8
max_storeys         = 8
detail              = 2
characters          = {characters}
"""


def bench_scenes(quick: bool) -> list[BenchScene]:
    """The default scene, towns at three sizes (and three walker counts), stability scenes."""
    out = [BenchScene("default", "main", default_scene_path().read_text())]
    if quick:
        out.append(BenchScene("town_2x2", "town", town_text(2, 16, "town_2x2"), "size", 2))
    else:
        # Town sizes with 16 walkers (the 8 x 8 one is assets/town_1m.toml: 1.06 M triangles),
        # and the 4 x 4 town with 4, 16 and 64 walkers, plus the 1 M town with 64.
        for blocks in (2, 4, 8):
            out.append(BenchScene(f"town_{blocks}x{blocks}", "town",
                                  town_text(blocks, 16, f"town_{blocks}x{blocks}"), "size",
                                  blocks))
        for n in (4, 64):
            out.append(BenchScene(f"town_4x4_c{n}", "town", town_text(4, n, f"town_4x4_c{n}"),
                                  "characters", n))
        out.append(BenchScene("town_8x8_c64", "town", town_text(8, 64, "town_8x8_c64"),
                              "characters", 64))
    for case in stability.cases(quick):
        out.append(BenchScene(f"stab_{case.name}", "stability", case.text, case.factor,
                              case.value, case.accuracy_expected))
    return out


def _p(**kw) -> tuple[tuple[str, object], ...]:
    return tuple(sorted(kw.items()))


def method_grid(scene: BenchScene, quick: bool, max_texture: int) -> list[RunSpec]:
    """Methods x parameters for one scene; the full grid on the default scene and the 1 M town."""
    k = scene.key
    defaults = [RunSpec(k, method) for method in registry.MAP_METHODS]
    if scene.group == "stability":
        if scene.factor == "maps":  # hundreds of character maps: keep their memory small
            small = _p(clump_resolution=256, character_resolution=256)
            return [RunSpec(k, "clumped", small), *(s for s in defaults if s.method != "clumped")]
        return defaults
    if quick:
        specs = [*defaults, RunSpec(k, "clumped", _p(clumping="world")),
                 RunSpec(k, "single", _p(single_resolution=1024)),
                 RunSpec(k, "csm", _p(cascade_resolution=1024))]
        if scene.group == "town":
            specs += [RunSpec(k, "clumped", _p(clump_count=n, clump_resolution=r,
                                               **{RERENDER: True})) for n, r in SWITCH_SERIES]
        return specs
    if k == "town_4x4":
        return [*defaults, RunSpec(k, "clumped", _p(clumping="world"))] + [
            RunSpec(k, "clumped", _p(clump_count=n, clump_resolution=r, **{RERENDER: True}))
            for n, r in SWITCH_SERIES]
    if k not in ("default", "town_8x8"):
        return [*defaults, RunSpec(k, "clumped", _p(clumping="world"))]
    specs = list(defaults)
    for clumping in ("light", "world"):
        for count in (4, 16, 64):
            specs.append(RunSpec(k, "clumped", _p(clumping=clumping, clump_count=count)))
    specs.append(RunSpec(k, "clumped", _p(clumping="world")))
    for res in (256, 1024):
        specs.append(RunSpec(k, "clumped", _p(character_resolution=res)))
    specs.append(RunSpec(k, "clumped", _p(clump_resolution=2048)))
    for res in (512, 1024, 2048, 8192, 16384):
        if res <= max_texture:
            specs.append(RunSpec(k, "single", _p(single_resolution=res)))
    for res in (2048, 8192):
        specs.append(RunSpec(k, "static-dynamic", _p(single_resolution=res)))
    for res in (1024, 4096):
        specs.append(RunSpec(k, "csm", _p(cascade_resolution=res)))
    for lam in (0.5, 0.95):
        specs.append(RunSpec(k, "csm", _p(cascade_lambda=lam)))
    return specs


def footprints(maps: list[MapRecord], cells: int = 1024) -> dict:
    """How the maps holding statics cover light space (directional lights only).

    ``footprint_overlap`` is the summed area of their rectangles over the area of their union
    (1: no two maps overlap; a fragment under an overlap may read several maps);
    ``static_texels_per_metre`` the median texel density of those maps.
    """
    out = {"static_maps": len(maps)}
    if not maps or any(m.fit.perspective for m in maps):
        return out
    rects = np.array([m.fit.rect for m in maps])
    lo, hi = rects[:, :2].min(axis=0), rects[:, 2:].max(axis=0)
    step = (hi - lo).max() / cells
    covered = np.zeros((cells + 1, cells + 1), bool)
    for x0, y0, x1, y1 in rects:
        i0, j0 = ((np.array([x0, y0]) - lo) / step).astype(int)
        i1, j1 = np.ceil((np.array([x1, y1]) - lo) / step).astype(int)
        covered[j0:j1, i0:i1] = True
    union = covered.sum() * step * step
    area = float(np.sum((rects[:, 2] - rects[:, 0]) * (rects[:, 3] - rects[:, 1])))
    out["footprint_overlap"] = area / union if union > 0 else float("nan")
    out["static_texels_per_metre"] = float(np.median([1.0 / m.fit.texel for m in maps]))
    return out


# -- one run --------------------------------------------------------------------------------
def orbit_view(scene: Scene, size: tuple[int, int], yaw_deg: float) -> View:
    """The scene camera turned by ``yaw_deg`` about the vertical through its target."""
    cam = scene.camera
    offset = np.asarray(cam.position, float) - np.asarray(cam.target, float)
    a = math.radians(yaw_deg)
    c, s = math.cos(a), math.sin(a)
    turned = np.array([c * offset[0] + s * offset[2], offset[1], -s * offset[0] + c * offset[2]])
    aspect = size[0] / size[1]
    return View(transforms.look_at(np.asarray(cam.target, float) + turned, cam.target),
                transforms.perspective(cam.fov, aspect, cam.near, cam.far))


def _stats(values: list[float]) -> tuple[float, float]:
    if not values:
        return float("nan"), float("nan")
    return float(np.median(values)), float(np.percentile(values, 95))


def flicker_rates(frames: list[dict]) -> dict[str, float]:
    """How often a surface point's lit state flips between consecutive frames.

    ``frames`` hold ``position`` (H, W, 3), ``object`` (H, W), ``view``, ``proj``, the method's
    visibility ``lit`` and, where the reference ran, Embree's ``exact``. Each pixel of frame k+1
    is projected into frame k; the pair counts when the pixel there sees the same object within
    one pixel footprint of the same point. Near a shadow edge the two samples can straddle it,
    so even exact shadows "flip" there: ``flicker_reference`` is that rate, ``flicker_raw`` the
    method's, and ``flicker`` the share of pairs where the method flips while the reference does
    not (the method's own instability).
    """
    counts = {"raw": 0, "reference": 0, "excess": 0}
    pairs = 0
    for a, b in zip(frames, frames[1:], strict=False):
        h, w = b["object"].shape
        valid = b["object"] >= 0
        p = b["position"][valid].astype(np.float64)
        clip = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ (a["proj"] @ a["view"]).T
        with np.errstate(invalid="ignore", divide="ignore"):
            ndc = clip[:, :2] / clip[:, 3:4]
        col = np.floor((ndc[:, 0] + 1) / 2 * w).astype(np.int64)
        row = np.floor((1 - ndc[:, 1]) / 2 * h).astype(np.int64)
        inside = (clip[:, 3] > 0) & (col >= 0) & (col < w) & (row >= 0) & (row < h)
        col, row = np.clip(col, 0, w - 1), np.clip(row, 0, h - 1)
        q = a["position"][row, col].astype(np.float64)
        footprint = clip[:, 3] * 2 / (h * a["proj"][1, 1])  # metres per pixel at that depth
        with np.errstate(invalid="ignore"):
            same = (inside & (a["object"][row, col] == b["object"][valid])
                    & (np.linalg.norm(q - p, axis=1) <= footprint))
        pairs += int(same.sum())
        method = same & ((a["lit"][row, col] >= 0.5) != (b["lit"][valid] >= 0.5))
        counts["raw"] += int(method.sum())
        if "exact" in b:
            exact = same & ((a["exact"][row, col] >= 0.5) != (b["exact"][valid] >= 0.5))
            counts["reference"] += int(exact.sum())
            counts["excess"] += int((method & ~exact).sum())
    if not pairs:
        return {}
    out = {"flicker_raw": counts["raw"] / pairs}
    if "exact" in frames[0]:
        out.update(flicker=counts["excess"] / pairs, flicker_reference=counts["reference"] / pairs)
    return out


def _score(ctx, scene: Scene, spec: RunSpec, opts: BenchOptions, tmp: Path) -> dict:
    """Error and flicker frames, with a G-buffer: dumped, then judged by the reference."""
    renderer = Renderer(ctx, scene, opts.size, spec.settings(), gbuffer=True)
    result = {"nan_pixels": 0}
    try:
        errors, mis, shadowed = [], 0, 0
        for j in range(opts.error_frames):
            t = j * ERROR_SPACING_S
            view = orbit_view(scene, opts.size, 10.0 * j)
            frame = renderer.render(t, view)
            lit = frame.gbuffer["lit"]
            result["nan_pixels"] += int(np.isnan(lit[frame.covered]).sum())
            if not opts.reference:
                continue
            stem = tmp / f"frame_{j:04d}"
            dumps.write_dump(stem, scene, view, opts.size, t, frame)
            err = score_dump(stem.with_suffix(".npz"), scene.light)
            errors.append(err["error"])
            mis += err["misclassified"]
            shadowed += err["shadowed"]
        if errors:
            # Pooled over the frames: misclassified pixels over shadowed pixels.
            result.update(error=mis / max(1, shadowed), misclassified=mis, shadowed=shadowed,
                          error_frames=len(errors))
        flicker_frames = []
        mesh = None
        t0 = 0.5
        for j in range(opts.flicker_frames):
            view = orbit_view(scene, opts.size, FLICKER_DEG * j)
            frame = renderer.render(t0, view)
            g = frame.gbuffer
            result["nan_pixels"] += int(np.isnan(g["lit"][frame.covered]).sum())
            entry = {"position": g["position"], "object": g["object"], "lit": g["lit"],
                     "view": view.view, "proj": view.proj}
            if opts.reference:
                if mesh is None:  # time is frozen: one geometry for every flicker frame
                    stem = tmp / "flicker"
                    dumps.write_dump(stem, scene, view, opts.size, t0, frame)
                    mesh = reference.load_geometry(stem.with_suffix(".glb"))
                entry["exact"] = reference.hard_visibility(mesh, g["position"], g["normal"],
                                                           scene.light)
            flicker_frames.append(entry)
        result.update(flicker_rates(flicker_frames))
    finally:
        renderer.release()
    return result


FAILURES = (GameError, RuntimeError, ValueError)


def measure_timing(ctx, scene: Scene, spec: RunSpec, opts: BenchOptions) -> dict:
    """The timing frames of one run: per-pass median and p95, counters, footprints."""
    out: dict = {}
    renderer = Renderer(ctx, scene, opts.size, spec.settings())
    try:
        out["clock"] = renderer.timer.clock
        g = renderer.geom
        out["static_triangles"] = g.triangle_count(range(g.first_static, g.first_character))
        out["characters"] = g.n_characters
        timed = []
        for k in range(opts.warmup + opts.frames):
            if spec.rerender:
                renderer.method.mark_rendered_lost()
            view = orbit_view(scene, opts.size, ORBIT_DEG * k)
            frame = renderer.render(k / FPS, view)
            if k >= opts.warmup:
                timed.append(frame)
        plan = renderer.method.plan(renderer.models(k / FPS), view)
        statics = set(range(g.first_static, g.first_character))
        out.update(footprints([m for m in plan.maps if statics.intersection(m.objects)]))
        for p in PASSES:
            ms = [f.ms.get(p, 0.0) for f in timed]
            out[f"{p}_ms_median"], out[f"{p}_ms_p95"] = _stats(ms)
            # The least-disturbed frame: on a shared machine other jobs only ever add time.
            out[f"{p}_ms_min"] = min(ms) if ms else float("nan")
        for name in ("maps_total", "maps_rendered", "triangles_to_maps", "texels_to_maps",
                     "camera_triangles", "maps_per_fragment"):
            out[name] = float(np.mean([getattr(f, name) for f in timed]))
        out["shadow_memory_mib"] = renderer.shadow_memory_bytes / 2**20
        out["notes"] = "; ".join(renderer.notes + floors.floor_warnings(scene))
    finally:
        renderer.release()
    return out


def combine(reps: list[dict]) -> dict:
    """One row from repeated timings: the median over repetitions of each pass's median and p95,
    and the spread of the total's medians ((max - min) / median)."""
    out = dict(reps[0])
    for p in PASSES:
        for stat in ("median", "p95"):
            out[f"{p}_ms_{stat}"] = float(np.median([r[f"{p}_ms_{stat}"] for r in reps]))
        out[f"{p}_ms_min"] = float(min(r[f"{p}_ms_min"] for r in reps))
    totals = [r["total_ms_median"] for r in reps]
    out["repeats"] = len(reps)
    out["total_ms_spread"] = (max(totals) - min(totals)) / out["total_ms_median"]
    return out


def run_one(ctx, bscene: BenchScene, scene: Scene, spec: RunSpec, opts: BenchOptions,
            timings: list | None = None) -> dict:
    """Measure one run; a method that raises gives a row with ``status`` = failed: why.

    ``timings``: timing results already measured (``--repeat``, interleaved with the scene's
    other runs); an exception in the list is raised here, as if measured now.
    """
    start = time.perf_counter()
    s = spec.settings()
    row: dict = {"run": spec.run_id(opts.size), "scene": bscene.key, "group": bscene.group,
                 "factor": bscene.factor, "value": bscene.value, "method": spec.method,
                 **{k: getattr(s, k) for k in PARAM_KEYS}, RERENDER: spec.rerender,
                 "width": opts.size[0], "height": opts.size[1], "frames": opts.frames,
                 "warmup": opts.warmup, **context.describe(ctx)}
    try:
        reps = timings if timings is not None else [measure_timing(ctx, scene, spec, opts)]
        for rep in reps:
            if isinstance(rep, BaseException):
                raise rep
        row.update(combine(reps))
        with tempfile.TemporaryDirectory(prefix="bench-", dir=opts.out) as tmp:
            row.update(_score(ctx, scene, spec, opts, Path(tmp)))
        row["status"] = "ok"
    except FAILURES as exc:
        row["status"] = f"failed: {type(exc).__name__}: {str(exc).splitlines()[0][:200]}"
    error = ctx.error
    if error != "GL_NO_ERROR":
        row["status"] = f"failed: {error}" if row.get("status") == "ok" else row["status"]
    row["seconds"] = time.perf_counter() - start
    return row


def interleaved_timings(ctx, scene: Scene, specs: list[RunSpec], opts: BenchOptions
                        ) -> dict[RunSpec, list]:
    """``opts.repeat`` timings of each run, round-robin over the scene's runs, so that a
    change in the machine's load over the sweep falls on every method alike."""
    timings: dict[RunSpec, list] = {spec: [] for spec in specs}
    for _ in range(opts.repeat):
        for spec in specs:
            if timings[spec] and isinstance(timings[spec][-1], BaseException):
                continue
            try:
                timings[spec].append(measure_timing(ctx, scene, spec, opts))
            except FAILURES as exc:
                timings[spec].append(exc)
    return timings


# -- the CSV ----------------------------------------------------------------------------------
def read_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def write_rows(path: Path, rows: list[dict]) -> None:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, extrasaction="ignore",
                            lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row.get(k, "")) for k in COLUMNS})
    outputs.write_bytes(path, buf.getvalue().encode())


def _cell(value):
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.10g}"
    return "" if value is None else value


def selected(key: str, patterns: Iterable[str] | None) -> bool:
    from fnmatch import fnmatch

    return patterns is None or any(fnmatch(key, p) for p in patterns)


def plan_runs(opts: BenchOptions, max_texture: int) -> list[tuple[BenchScene, RunSpec]]:
    runs = []
    for bscene in bench_scenes(opts.quick):
        if not selected(bscene.key, opts.scenes):
            continue
        for spec in method_grid(bscene, opts.quick, max_texture):
            if opts.methods is None or spec.method in opts.methods:
                runs.append((bscene, spec))
    return runs


def run(opts: BenchOptions, ctx=None) -> dict:
    """Run the sweep (skipping finished rows), then write the charts; returns a summary.

    ``ctx``: a GL context to use (and leave open); by default one is made and released here.
    """

    opts.out.mkdir(parents=True, exist_ok=True)
    (opts.out / "scenes").mkdir(exist_ok=True)
    clean(opts.out)
    csv_path = opts.out / "bench.csv"
    rows = read_rows(csv_path)
    done = {r["run"] for r in rows}
    own = ctx is None
    ctx = context.create_headless() if own else ctx
    try:
        runs = plan_runs(opts, int(ctx.info["GL_MAX_TEXTURE_SIZE"]))
        todo = [(b, s) for b, s in runs if s.run_id(opts.size) not in done]
        opts.log(f"bench: {len(runs)} runs, {len(runs) - len(todo)} already in {csv_path}, "
                 f"{len(todo)} to go ({context.describe(ctx)['renderer']})")
        bar = _progress(len(todo), opts.progress)
        loaded: tuple[str, Scene] | None = None
        timings: dict = {}
        try:
            for bscene, spec in todo:
                interrupts.check()
                bar.set_description(f"{bscene.key} {spec.method}")
                if loaded is None or loaded[0] != bscene.key:
                    loaded = (bscene.key, _load(bscene, opts.out / "scenes"))
                    if opts.repeat > 1:
                        bar.set_description(f"{bscene.key}: {opts.repeat} interleaved timings")
                        specs = [sp for b, sp in todo if b.key == bscene.key]
                        timings = interleaved_timings(ctx, loaded[1], specs, opts)
                if opts.repeat > 1:
                    row = run_one(ctx, bscene, loaded[1], spec, opts, timings.pop(spec))
                else:
                    row = run_one(ctx, bscene, loaded[1], spec, opts)
                rows.append(row)
                write_rows(csv_path, rows)
                bar.update(1)
        finally:
            bar.close()
    finally:
        if own:
            ctx.release()
    written = charts.write_all(rows, opts.out / "charts")
    summary = acceptance(rows)
    outputs.write_json(opts.out / "summary.json", summary)
    return {"csv": str(csv_path), "rows": len(rows), "charts": [str(p) for p in written],
            "summary": summary}


def _load(bscene: BenchScene, folder: Path) -> Scene:
    """Parse a bench scene; generated ones are also written to ``folder`` for ``capture``."""
    if bscene.key == "default":
        return parse_scene(bscene.text, source=default_scene_path(),
                           base_dir=default_scene_path().parent)
    path = folder / f"{bscene.key}.toml"
    if not path.exists():
        outputs.write_bytes(path, bscene.text.encode())
    return parse_scene(bscene.text, source=path, base_dir=folder)


def _progress(total: int, enabled: bool):
    try:
        from tqdm import tqdm
    except ImportError as exc:
        raise GameError("bench needs tqdm and matplotlib: pip install -e '.[bench]'") from exc
    return tqdm(total=total, disable=not enabled, unit="run", file=sys.stderr,
                dynamic_ncols=True)


# -- acceptance figures -----------------------------------------------------------------------
def is_default(row: dict) -> bool:
    """The row's parameters are the method's defaults."""
    return row["run"].split("|")[2] == "defaults"


def compare(rows: list[dict], scene: str, baseline: str) -> dict | None:
    """clumped (defaults) against a baseline's runs on one scene, at equal or lower error.

    The baseline run compared is the cheapest one whose error is at least clumped's (clumped is
    then at equal or lower error); where every baseline run is more accurate, the one closest
    to clumped's error is taken and ``clumped_error_lower`` is False.
    """
    ok = [r for r in rows if r["scene"] == scene and r.get("status") == "ok"
          and not math.isnan(row_number(r, "error"))]
    mine = [r for r in ok if r["method"] == "clumped" and is_default(r)]
    theirs = [r for r in ok if r["method"] == baseline]
    if not mine or not theirs:
        return None
    m = mine[0]
    e, t = row_number(m, "error"), row_number(m, "total_ms_median")
    t_min = row_number(m, "total_ms_min")
    worse = [r for r in theirs if row_number(r, "error") >= e]
    if worse:
        # Among the baseline runs no more accurate than clumped, the most accurate (then the
        # cheapest): the fairest match, not the cheapest coarse map.
        pick = min(worse, key=lambda r: (row_number(r, "error"), row_number(r, "total_ms_median")))
    else:
        pick = min(theirs, key=lambda r: row_number(r, "error") - e)
    return {"scene": scene, "baseline": pick["run"], "clumped_run": m["run"],
            "clumped_ms": t, "clumped_error": e,
            "baseline_ms": row_number(pick, "total_ms_median"),
            "baseline_error": row_number(pick, "error"),
            "speedup": row_number(pick, "total_ms_median") / t if t > 0 else float("nan"),
            # The same ratio from each run's least-disturbed frame (robust to other jobs' load).
            "clumped_ms_min": t_min, "baseline_ms_min": row_number(pick, "total_ms_min"),
            "speedup_min": row_number(pick, "total_ms_min") / t_min if t_min > 0 else float("nan"),
            "clumped_error_lower": bool(worse)}


def acceptance(rows: list[dict]) -> dict:
    """The issue's acceptance figures, from this run's rows."""
    out: dict = {}
    if rows:
        out["renderer"] = rows[-1].get("renderer")
        out["version"] = rows[-1].get("version")
        out["clock"] = rows[-1].get("clock")
    for scene in sorted({r["scene"] for r in rows if r["group"] in ("main", "town")}):
        for baseline in ("single", "csm", "static-dynamic"):
            c = compare(rows, scene, baseline)
            if c is not None:
                out.setdefault("comparisons", []).append(c)
            c = compare([r for r in rows if r["method"] != baseline or is_default(r)], scene,
                        baseline)
            if c is not None:  # against the baseline at its defaults (what engines ship)
                out.setdefault("default_comparisons", []).append(c)
        ok = [r for r in rows if r["scene"] == scene and r.get("status") == "ok"
              and not math.isnan(row_number(r, "error"))]
        mine = [r for r in ok if r["method"] == "clumped" and is_default(r)]
        if mine:
            # On the front against the baselines: no baseline run both faster and more accurate.
            t, e = row_number(mine[0], "total_ms_median"), row_number(mine[0], "error")
            beaten_by = [r["run"] for r in ok if r["method"] != "clumped"
                         and row_number(r, "total_ms_median") <= t and row_number(r, "error") <= e
                         and (row_number(r, "total_ms_median") < t or row_number(r, "error") < e)]
            out.setdefault("clumped_default_on_front", {})[scene] = not beaten_by
            if beaten_by:
                out.setdefault("clumped_default_beaten_by", {})[scene] = beaten_by
    return out


def clean(out: Path) -> None:
    """Remove leftovers of interrupted runs (their temp dump folders)."""
    for tmp in out.glob("bench-*"):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
