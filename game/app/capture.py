"""Headless frame capture (``python -m game capture``): frames, dumps and stats
(docs/reference.md).

Scene -> Renderer -> Frame -> files. Frame k is rendered at scene time ``time + k / fps``. A run
that takes more than a moment shows its progress on a terminal (game/app/progress.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from game.app import headless, progress
from game.gpu import context
from game.render.depth_first import DepthFirst
from game.render.passes import PASSES_AND_TOTAL
from game.render.renderer import Frame, Renderer, View
from game.scene import Scene, floors
from game.shadows.plan import ShadowSettings
from game.soft.methods import TraceSettings


@dataclass
class CaptureOptions(headless.HeadlessRun):
    debug_view: str = "none"
    overlay: bool = False       # draw the timing overlay (game/app/window/overlay.py) in frames
    settings: ShadowSettings = field(default_factory=ShadowSettings)
    soft: TraceSettings | None = None  # light the frames by the linear light, soft shadows
    cull: bool = True           # camera pass: only triangles that can cover a pixel centre
    depth_first: DepthFirst = DepthFirst.AUTO  # camera pass: its depth before it shades


def frame_stats(index: int, t: float, frame: Frame) -> dict:
    """One frame's entry of the stats file (docs/reference.md, section 4)."""
    ms = {name: round(value, 4) for name, value in frame.ms.items()}
    characters = frame.characters.as_dict() if frame.characters is not None else {}
    return {"frame": index, "time": t, "ms": ms, **ms,
            "maps_rendered": frame.maps_rendered, "maps_cached": frame.maps_cached,
            "maps_total": frame.maps_total, "triangles_to_maps": frame.triangles_to_maps,
            "texels_to_maps": frame.texels_to_maps, "maps_waiting": frame.maps_waiting,
            "camera_triangles": frame.camera_triangles, **characters,
            "depth_first": frame.depth_first,
            "fragments_per_pixel": (None if frame.fragments_per_pixel is None
                                    else round(frame.fragments_per_pixel, 4)),
            "maps_per_fragment": round(frame.maps_per_fragment, 5),
            **({} if frame.map_candidates is None else {
                "map_candidates_per_fragment": round(frame.map_candidates_per_fragment, 5)}),
            **headless.resource_stats(frame)}


def _view_notes(opts: CaptureOptions) -> list[str]:
    """What a debug view cannot show in this capture."""
    if opts.debug_view == "cache" and opts.frames == 1:
        return ["--debug-view cache: the first frame draws every map, so it is all red (drawn "
                "this frame); capture two frames or more to see the cached maps in green"]
    return []


def run(ctx, scene: Scene, opts: CaptureOptions) -> dict:
    """Render ``opts.frames`` frames and write them; returns the stats document.

    Ctrl-C ends the run after the frame being written (its files and its stats entry are kept
    whole), writes the stats of the finished frames with ``"interrupted": true``, and raises
    KeyboardInterrupt.
    """
    opts.prepare()

    renderer = Renderer(ctx, scene, opts.size, opts.settings,
                        gbuffer=opts.dump or opts.soft is not None, clock=opts.clock,
                        cull=opts.cull, depth_first=opts.depth_first)
    renderer.debug_view = opts.debug_view
    renderer.count_candidates = opts.stats is not None
    hud = _overlay() if opts.overlay else None
    view = View.from_camera(scene.camera, opts.size)
    report = progress.Progress("capture", opts.frames)
    if report.enabled:  # a long trace (--soft, traced) goes in bands of rows, each reported
        renderer.traced.progress = report.part
    interrupted = True

    def render(t: float) -> Frame:
        report.frame()
        frame = renderer.render(t, view, soft=opts.soft)
        if hud is not None:
            frame.image = hud.draw_over_frame(renderer, frame, 1.0 / opts.fps)
        return frame

    try:
        frames, interrupted = opts.run_frames(scene, view, render, frame_stats)
        stats = {
            **context.describe(ctx), "clock": renderer.timer.clock,
            "scene": scene.given,
            "scene_sha256": scene.sha256,
            "method": opts.settings.method, "size": list(opts.size),
            # What ran: the settings after the GL limits and the budget (see ``notes``), and
            # what was asked for.
            "settings": dataclasses.asdict(renderer.settings),
            "settings_asked": dataclasses.asdict(opts.settings),
            "shadow_memory_mib": round(renderer.shadow_memory_bytes / 2**20, 3),
            "static_triangles": renderer.geom.triangle_count(
                range(renderer.geom.first_static, renderer.geom.first_character)),
            "characters": renderer.geom.n_characters,
            "notes": renderer.notes + floors.floor_warnings(scene) + _view_notes(opts),
            "interrupted": interrupted,
            "frames": frames,
        }
    finally:
        report.close(done=not interrupted)
        if hud is not None:
            hud.release()
        renderer.release()
    opts.finish(stats, frames)
    return stats


def _overlay():
    """The timing overlay, imported only when asked for (it loads imgui)."""
    from game.app.window.overlay import Overlay

    return Overlay()


def summary(stats: dict) -> str:
    """One line: medians over the frames after the first."""
    keys = PASSES_AND_TOTAL
    ms = np.array([[f["ms"].get(k, 0.0) for k in keys] for f in stats["frames"]])
    ms = ms[1:] if len(ms) > 1 else ms
    med = dict(zip(keys, np.median(ms, axis=0).tolist(), strict=True))
    return (f"{len(stats['frames'])} frames, median ms: "
            + ", ".join(f"{k} {v:.2f}" for k, v in med.items())
            + f" ({stats['clock']} on {stats['renderer']})")

