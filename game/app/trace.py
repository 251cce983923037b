"""Headless soft-shadow runs (``python -m game trace``).

Scene -> Renderer (G-buffer, then the tracer and the soft composite) -> files:
``frame_kkkk.png`` (the soft-shadowed image), with ``--dump`` the arrays of docs/reference.md
section 3 plus ``soft``, with ``--stats`` the JSON of section 4 plus the tracer's counters. A run
that takes more than a moment shows its progress on a terminal (game/app/progress.py).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from game.app import headless, progress
from game.errors import GameError
from game.gpu import context
from game.render.renderer import Frame, Renderer, View
from game.scene import Scene
from game.soft.methods import is_raster
from game.soft.results import COUNTERS, TraceResult
from game.soft.tracer import TraceSettings


@dataclass
class TraceOptions(headless.HeadlessRun):
    settings: TraceSettings = field(default_factory=TraceSettings)


def frame_stats(index: int, t: float, frame: Frame, result: TraceResult) -> dict:
    """One frame of the trace stats: the pass times, the G-buffer render, the mean counters."""
    ms = {k: round(v, 4) for k, v in result.ms.items()}
    ms["gbuffer"] = round(frame.ms.get("gbuffer", 0.0), 4)
    ms["composite"] = round(frame.ms.get("composite", 0.0), 4)
    means = {k: round(v, 4) for k, v in result.means().items()}
    covered = result.covered
    return {"frame": index, "time": t, "ms": ms, **ms,
            "maps_rendered": frame.maps_rendered, "triangles_to_maps": frame.triangles_to_maps,
            "shaded_points": int(covered.sum()),
            # llvmpipe's loop budget: the dispatches the trace took, the loop iterations each
            # point had per dispatch, samples per dispatch of the most split point, and the
            # points still cut short (0).
            "rounds": result.rounds, "step_budget": result.step_budget,
            "samples_per_dispatch": result.samples_per_dispatch,
            "truncated_points": result.truncated,
            "mean_visibility": round(float(np.nanmean(result.visibility)), 6)
            if covered.any() else None,
            **means, **result.maps, **headless.resource_stats(frame)}


def run(ctx, scene: Scene, opts: TraceOptions) -> dict:
    """Trace ``opts.frames`` frames and write them; returns the stats document (Ctrl-C as in
    :func:`game.app.capture.run`)."""
    if scene.linear_light is None:
        raise GameError("the scene has no [linear_light] to trace")
    opts.prepare()
    renderer = Renderer(ctx, scene, opts.size, gbuffer=True, clock=opts.clock)
    view = View.from_camera(scene.camera, opts.size)
    report = progress.Progress("trace", opts.frames)
    if report.enabled:  # a long trace goes in bands of rows, each reported
        renderer.traced.progress = report.part
    interrupted = True

    def render(t: float) -> Frame:
        report.frame()
        return renderer.render(t, view, soft=opts.settings)

    try:
        frames, interrupted = opts.run_frames(
            scene, view, render, lambda k, t, frame: frame_stats(k, t, frame, frame.soft))
        stats = {
            **context.describe(ctx), **_pass_stats(renderer, opts.settings),
            "scene": scene.given,
            "scene_sha256": scene.sha256,
            "method": opts.settings.method, "samples": opts.settings.samples,
            "size": list(opts.size), "settings": asdict(opts.settings),
            "counters": list(COUNTERS),
            "interrupted": interrupted,
            "frames": frames,
        }
    finally:
        report.close(done=not interrupted)
        renderer.release()
    opts.finish(stats, frames)
    return stats


def _pass_stats(renderer: Renderer, settings: TraceSettings) -> dict:
    """The clock, and what the pass that ran is made of: the tracer's grid and buffers, or the
    raster methods' maps and tuning."""
    if is_raster(settings.method):
        raster = renderer.traced.raster
        if raster is None:  # interrupted before the first frame
            return {"clock": renderer.timer.clock}
        return {"clock": raster.timer.clock, "maps": raster.describe(),
                "memory_bytes": raster.memory_bytes()}
    tracer = renderer.soft_tracer
    if tracer is None:
        return {"clock": renderer.timer.clock}
    return {"clock": tracer.timer.clock, "grid": tracer.grid.describe(),
            "memory_bytes": {**tracer.memory_bytes(),
                             "voxel_cache_per_point": settings.voxel_cache_bytes_per_point}}


def summary(stats: dict) -> str:
    """One line: the last frame's times and counters (a raster method: its map passes)."""
    f = stats["frames"][-1]
    if "soft_maps_rendered" in f:
        return (f"{stats['method']}: {f['samples_per_dispatch']} light point(s), "
                f"maps {f['build']:.1f} ms ({f['soft_maps_rendered']} drawn, "
                f"{f['soft_maps_static_cached']} cached), lookup {f['trace']:.1f} ms, total "
                f"{f['total']:.1f} ms ({stats['clock']} on {stats['renderer']})")
    return (f"{stats['method']} N={stats['samples']}: build {f['build']:.1f} ms, trace "
            f"{f['trace']:.1f} ms, total {f['total']:.1f} ms; per point: ray-triangle "
            f"{f['ray_triangle_tests']:.2f}, triangle-triangle {f['triangle_triangle_tests']:.2f},"
            f" voxels {f['voxels_visited']:.2f}, bytes read {f['bytes_total']:.0f} "
            f"({stats['clock']} on {stats['renderer']})")
