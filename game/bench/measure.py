"""One benchmark run, measured: timing frames, error frames scored by Embree, flicker frames.

- timing frames (no G-buffer): the camera orbits the scene camera's target by ``ORBIT_DEG``
  per frame while the characters walk at 30 frames per scene second; per pass, the median and
  p95 over the frames after the warm-up; maps, triangles and texels drawn into maps per frame;
  shadow memory; maps read per shaded pixel;
- error frames (G-buffer dumps, docs/reference.md section 3): written to disk and scored by the
  independent Embree reference (game/reference/), which reads only the dump files;
- flicker frames: scene time frozen, only the camera moves (``FLICKER_DEG`` per frame); a pixel
  flickers when the surface point it sees was lit in one frame and shadowed in the next while
  the reference's verdict on the same two samples did not change (``flicker_rates``).
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from game import transforms
from game.app import dumps, interrupts, outputs
from game.bench.runs import (
    ERROR_SPACING_S,
    FLICKER_DEG,
    FPS,
    ORBIT_DEG,
    PARAM_KEYS,
    PASSES,
    RERENDER,
    BenchOptions,
    BenchScene,
    RunSpec,
)
from game.errors import GameError
from game.gpu import context
from game.reference import hard as reference
from game.reference.score import score_dump_lights
from game.render.renderer import Renderer, View
from game.scene import Scene, floors
from game.shadows.plan import MapRecord


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
        errors, mis, shadowed, either = [], 0, 0, 0
        per_light = [[0, 0] for _ in scene.lights]  # misclassified, shadowed either
        for j in range(opts.error_frames):
            interrupts.check()
            t = j * ERROR_SPACING_S
            view = orbit_view(scene, opts.size, 10.0 * j)
            frame = renderer.render(t, view)
            lit = frame.gbuffer["lit"]
            result["nan_pixels"] += int(np.isnan(lit[frame.covered]).sum())
            if not opts.reference:
                continue
            stem = tmp / f"frame_{j:04d}"
            dumps.write_dump(stem, scene, view, opts.size, t, frame)
            scores = score_dump_lights(stem.with_suffix(".npz"), scene.lights)["lights"]
            errors.append(scores[0]["error"])
            for k, err in enumerate(scores):
                per_light[k][0] += err["misclassified"]
                per_light[k][1] += err["shadowed_either"]
                mis += err["misclassified"]
                shadowed += err["shadowed"]
                either += err["shadowed_either"]
        if errors:
            # Pooled over the frames and the lights: misclassified pixels over pixels either
            # side shadows; and the worst light's, pooled over the frames.
            result.update(error=mis / max(1, either), misclassified=mis, shadowed=shadowed,
                          error_frames=len(errors),
                          error_worst_light=max(m / max(1, e) for m, e in per_light))
        flicker_frames = []
        mesh = None
        t0 = 0.5
        for j in range(opts.flicker_frames):
            interrupts.check()
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


class Timing:
    """The timing frames of one run, frame by frame, so that several runs can take turns (see
    :func:`interleaved_timings`). Owns its renderer until :meth:`result` or :meth:`release`."""

    def __init__(self, ctx, scene: Scene, spec: RunSpec, opts: BenchOptions):
        self.scene, self.spec, self.opts = scene, spec, opts
        self.renderer = Renderer(ctx, scene, opts.size, spec.settings(), clock=opts.clock)
        self.timed: list = []
        self.view = None
        self.k = 0

    @property
    def frames(self) -> int:
        return self.opts.warmup + self.opts.frames

    def frame(self) -> None:
        """Render the next frame; the ones after the warm-up are kept."""
        k, renderer = self.k, self.renderer
        if self.spec.rerender:
            renderer.shadows.mark_rendered_lost()
        self.view = orbit_view(self.scene, self.opts.size, ORBIT_DEG * k)
        # The last frame also counts the map records its pixels consider (outside its timings).
        renderer.count_candidates = k == self.frames - 1
        frame = renderer.render(k / FPS, self.view)
        if k >= self.opts.warmup:
            self.timed.append(frame)
        self.k += 1

    def result(self) -> dict:
        """Per-pass median, p95 and least-disturbed frame; counters; footprints. Releases the
        renderer."""
        out: dict = {}
        try:
            renderer, timed = self.renderer, self.timed
            out["clock"] = renderer.timer.clock
            g = renderer.geom
            out["static_triangles"] = g.triangle_count(range(g.first_static, g.first_character))
            out["characters"] = g.n_characters
            out["lights"] = len(self.scene.lights)
            # Light 0's maps as the last frame drew them (sized for its view).
            span = renderer.last_spans[0]
            maps = renderer.last_plan.maps[span.first_map:span.first_map + span.map_count]
            statics = set(range(g.first_static, g.first_character))
            out.update(footprints([m for m in maps if statics.intersection(m.objects)]))
            for p in PASSES:
                ms = [f.ms.get(p, 0.0) for f in timed]
                out[f"{p}_ms_median"], out[f"{p}_ms_p95"] = _stats(ms)
                # The least-disturbed frame: on a shared machine other jobs only ever add time.
                out[f"{p}_ms_min"] = min(ms) if ms else float("nan")
            for name in ("maps_total", "maps_rendered", "triangles_to_maps", "texels_to_maps",
                         "camera_triangles", "maps_per_fragment"):
                out[name] = float(np.mean([getattr(f, name) for f in timed]))
            last = timed[-1].map_candidates_per_fragment if timed else None
            out["map_candidates_per_fragment"] = float("nan") if last is None else last
            # The share of the timed frames whose camera pass drew its depth first.
            out["depth_first"] = float(np.mean([f.depth_first for f in timed]))
            out["shadow_memory_mib"] = renderer.shadow_memory_bytes / 2**20
            out["notes"] = "; ".join(renderer.notes + floors.floor_warnings(self.scene))
        finally:
            self.release()
        return out

    def release(self) -> None:
        if self.renderer is not None:
            self.renderer.release()
            self.renderer = None


def measure_timing(ctx, scene: Scene, spec: RunSpec, opts: BenchOptions) -> dict:
    """The timing frames of one run, one after another (see :class:`Timing`)."""
    timing = Timing(ctx, scene, spec, opts)
    try:
        for _ in range(timing.frames):
            interrupts.check()  # a signal inside GL code is only recorded
            timing.frame()
    except BaseException:
        timing.release()
        raise
    return timing.result()


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
    row: dict = {"run": spec.run_id(opts.size), "scene": bscene.key,
                 "scene_sha256": bscene.sha256, "group": bscene.group,
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
        if isinstance(exc, outputs.WriteError):  # a full disk fails every run after it too
            raise
        first = str(exc).splitlines()[0][:200] if str(exc) else ""
        row["status"] = f"failed: {type(exc).__name__}: {first}"
    error = ctx.error
    if error != "GL_NO_ERROR":
        row["status"] = f"failed: {error}" if row.get("status") == "ok" else row["status"]
    row["seconds"] = time.perf_counter() - start
    return row


def interleaved_timings(ctx, scene: Scene, specs: list[RunSpec], opts: BenchOptions
                        ) -> dict[RunSpec, list]:
    """``opts.repeat`` timings of each run. Within a repetition the runs take turns frame by
    frame (each renders frame k, then each renders frame k + 1), so that a change in the
    machine's speed, which lasts seconds, falls on every method alike and the ratios between
    them hold even where the milliseconds move."""
    timings: dict[RunSpec, list] = {spec: [] for spec in specs}
    for _ in range(opts.repeat):
        running: dict[RunSpec, Timing] = {}
        try:
            for spec in specs:
                if timings[spec] and isinstance(timings[spec][-1], BaseException):
                    continue
                try:
                    running[spec] = Timing(ctx, scene, spec, opts)
                except FAILURES as exc:
                    timings[spec].append(exc)
            for _ in range(opts.warmup + opts.frames):
                # A signal that came inside GL code is only recorded: raise it here.
                interrupts.check()
                for spec, timing in list(running.items()):
                    try:
                        timing.frame()
                    except FAILURES as exc:
                        timing.release()
                        del running[spec]
                        timings[spec].append(exc)
            for spec, timing in running.items():
                timings[spec].append(timing.result())
        finally:
            for timing in running.values():
                timing.release()
    return timings
