"""The window with soft shadows, measured and pictured (``bash docs/soft_window.sh``, and the
window suite, game/bench/window_suite.py, for its frame rates).

``fps``: the walkaround on GLFW's null platform, the built-in scene at 960x540, its walkers
walking and the camera still (or turning ``--turn`` degrees a frame, back and forth within
:data:`SWEEP` degrees of its first view), with or without soft shadows, any hard
method (``--method``), as the renderer draws it or as ``play`` shows it (``--as-shown``: the
overlay and FXAA); frames after a warm-up (the camera turning, so that a still camera's timed
frames start with its view's first) are timed by the CPU time of this process (with
``LP_NUM_THREADS=0`` llvmpipe rasterises in the calling thread, so other processes' load does
not count) and by wall time (noisy on a shared machine).

``shots``: the same window, no overlay and no FXAA (the picture is the renderer's), still
(characters paused) after 0, 1, 5 and 60 seconds of wall time (a still view settles to the
exact picture as it goes: game/soft/settle.py), then walking after 1 and 5; each
beside the ``analytic`` visibility of the same view and scene time, rendered full size by the
same renderer, with the RMSE between them: of the soft visibility and of the pictures.

``refine``: the same window still (characters paused), a frame at a time, with a still view's
refining ending at ``--points`` points along the segment (game/soft/still_lookups.py): the
visibility's RMSE against ``analytic`` after each frame, and each frame's milliseconds (the
whole frame, and its refining round).

Each mode runs in its own process (a window's GL context per process) and prints one JSON line.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import imgui_bundle  # noqa: F401 - before glfw

# isort: split
import numpy as np

from game.app import outputs
from game.app.window.walkaround import PlayOptions, Walkaround
from game.errors import GameError
from game.gpu import context
from game.scene import load_scene
from game.shadows import registry
from game.soft import still_lookups
from game.soft.methods import TraceSettings

DEFAULT_SCENE = Path(__file__).resolve().parents[2] / "assets" / "default.toml"
SIZE = (960, 540)
WARMUP_FRAMES = 3
WARMUP_TURN = 1.0   # degrees a warm-up frame turns the camera by
SWEEP = 30.0        # a turning camera's reach either side of its first timed view, degrees
ANALYTIC = TraceSettings(method="analytic")


def _window(scene_path: str, soft: bool, method: str | None = None,
            as_shown: bool = False) -> Walkaround:
    """The window on the null platform; ``as_shown``: with the overlay and FXAA, as ``play``
    opens it (else the renderer's own picture); ``method`` the hard-shadow method (default:
    the window's)."""
    scene = load_scene(Path(scene_path) if scene_path else DEFAULT_SCENE)
    opts = PlayOptions(size=SIZE, platform="null", soft=soft, overlay=as_shown,
                       antialias=as_shown, frames=10**9)
    if method is not None:
        opts.settings = dataclasses.replace(opts.settings, method=method)
    return Walkaround(scene, opts)


def _turn(app: Walkaround, degrees: float) -> None:
    """Turn the window's camera by ``degrees`` of yaw, as the mouse would."""
    if degrees:
        app.controller.camera.yaw += degrees
        app.controller.moved = True


def _sweep(frame: int, turn: float) -> int:
    """Which way timed frame ``frame`` turns (1 or -1): back and forth within :data:`SWEEP`
    degrees either side of the first view, so that every turning run looks at the same part of
    the scene however many frames it times."""
    half = max(1, round(SWEEP / abs(turn))) if turn else 1
    return 1 if ((frame + half) // (2 * half)) % 2 == 0 else -1


def fps(scene_path: str, soft: bool, frames: int, turn: float = 0.0, method: str | None = None,
        as_shown: bool = False) -> dict:
    """Frames per second of the window, by CPU time and by wall time, and its shading pass's
    median milliseconds; the camera still, or turning by ``turn`` degrees a frame
    (``method`` and ``as_shown`` as :func:`_window` takes them)."""
    app = _window(scene_path, soft, method, as_shown)
    try:
        # The warm-up turns the camera, so the first timed frame is a still view's first: a
        # still view's timed frames hold its refining rounds (game/soft/still_lookups.py).
        for _ in range(WARMUP_FRAMES):
            _turn(app, WARMUP_TURN)
            app.step(1 / 30)
        cpu, wall = time.process_time(), time.perf_counter()
        last, shade = wall, []
        for k in range(frames):
            now = time.perf_counter()
            _turn(app, turn * _sweep(k, turn))
            app.step(now - last)
            shade.append(app.last_figures.ms.get("shade", float("nan")))
            last = now
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        soft_method = app.soft_settings.method if soft else None
        settings = app.renderer.settings
        gl = context.describe(app.ctx)
    finally:
        app.close()
    return {"soft": soft, "soft_method": soft_method, "method": settings.method,
            "pcf": settings.pcf, "as_shown": as_shown, "frames": frames, "turn_degrees": turn,
            "width": SIZE[0], "height": SIZE[1], "sweep_degrees": SWEEP if turn else 0.0,
            "fps_cpu": round(frames / cpu, 3), "fps_wall": round(frames / wall, 3),
            "ms_cpu": round(cpu / frames * 1e3, 2),
            "shade_ms": round(float(np.median(shade)), 2), **gl}


def _visibility(app: Walkaround) -> np.ndarray:
    """The visibility the window's soft picture was lit by, (H, W) with row 0 at the top."""
    return app.renderer.traced.window_visibility(app.renderer.target)


def _analytic(app: Walkaround) -> tuple[np.ndarray, np.ndarray]:
    """The analytic picture and visibility of the window's view and scene time."""
    traced = app.renderer.traced
    size = app.renderer.size
    view = app.view(size)
    traced.reduce_soft(None)   # the window's next frame asks for its reduced trace again
    frame = app.renderer.render(app.scene_time, view, read=True, soft=ANALYTIC)
    return frame.image, frame.soft.visibility


def _rmse(visibility: np.ndarray, exact: np.ndarray) -> float:
    """The RMSE of ``visibility`` against ``exact`` where ``exact`` shows geometry."""
    covered = np.isfinite(exact)
    return float(np.sqrt(np.mean((visibility[covered] - exact[covered]) ** 2)))


def _compare(app: Walkaround, out: Path, name: str) -> dict:
    """Save the window's picture and, beside it, the analytic one; the RMSEs between them."""
    window = app.read_screen(app.renderer.size)
    vis = _visibility(app)
    image, exact = _analytic(app)
    vis_rmse = _rmse(vis, exact)
    diff = (window.astype(np.float64) - image.astype(np.float64)) / 255.0
    image_rmse = float(np.sqrt(np.mean(diff ** 2)))
    outputs.write_png(out / f"soft_window_{name}.png", window)
    outputs.write_png(out / f"soft_window_{name}_analytic.png",
                      np.concatenate([window, image], axis=1))
    return {"name": name, "rmse_visibility": round(vis_rmse, 5),
            "rmse_image": round(image_rmse, 5)}


def _run_until(app: Walkaround, seconds: float, spent: float) -> float:
    """Step the window in real time until it has run ``seconds`` of wall time in all, of which
    ``spent`` so far; returns the time it has run."""
    last = time.perf_counter()
    while True:   # at least one frame: the one the picture shows
        now = time.perf_counter()
        app.step(now - last)
        spent += time.perf_counter() - now
        last = now
        if spent >= seconds:
            return spent


STILL_SHOTS = (0.0, 1.0, 5.0, 60.0)   # seconds of a still window's time at its pictures
WALKING_SHOTS = (1.0, 5.0)


def shots(scene_path: str, out: Path) -> dict:
    """The still and walking pictures, each beside the analytic one, each from a window of its
    own (rendering the analytic picture starts the window's still view again). The seconds are
    the window's own after its first frame, which compiles the shaders and is not counted."""
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for walking, times in ((False, STILL_SHOTS), (True, WALKING_SHOTS)):
        for seconds in times:
            app = _window(scene_path, True)
            try:
                app.paused = not walking
                app.scene_time = 3.0       # the walkers spread over the square
                app.step(0.0)
                spent = _run_until(app, seconds, 0.0) if seconds else 0.0
                state = app.renderer.traced.reduced_state
                name = f"{'walking' if walking else 'still'}_{seconds:.0f}s"
                frames = app.frames
                row = _compare(app, out, name)
                rows.append({**row, "frames": frames, "seconds": round(spent, 2),
                             "soft_method": app.soft_settings.method, "round": state.round,
                             "phase": state.phase, "phases": state.phases,
                             "settled": round(state.settled, 4)})
            finally:
                app.close()
    return {"size": list(SIZE), "shots": rows}


def refine(scene_path: str, points: int, frames: int, every: int = 1) -> dict:
    """A still view's visibility against ``analytic`` after every ``every``-th of ``frames``
    frames and the last (pairs of frame and RMSE), its refining ending at ``points`` points
    along the segment (its first frame compiles); each frame's milliseconds, and the share of
    the pixels it has settled to the exact visibility (game/soft/settle.py)."""
    still_lookups.REFINE_POINTS = points
    app = _window(scene_path, True)
    try:
        app.paused = True
        app.scene_time = 3.0       # the walkers spread over the square, as in ``shots``
        shown, ms, settled = {}, [], []
        for k in range(frames):
            app.step(0.0)
            if k % every == 0 or k == frames - 1:
                shown[k] = _visibility(app)
            ms.append(app.last_figures.ms)
            settled.append(round(app.renderer.traced.reduced_state.settled, 4))
        _, exact = _analytic(app)   # last: it starts the window's still view again
    finally:
        app.close()
    return {"size": list(SIZE), "soft_method": "segment-maps", "refine_points": points,
            "rmse_visibility": [[k, round(_rmse(v, exact), 5)] for k, v in shown.items()],
            "total_ms": [round(m.get("total", 0.0), 1) for m in ms],
            "refine_ms": [round(m.get("soft_refine", 0.0), 1) for m in ms],
            "settle_ms": [round(m.get("soft_settle", 0.0), 1) for m in ms],
            "settled": settled}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m game.bench.soft_window")
    parser.add_argument("mode", choices=("fps", "shots", "refine"))
    parser.add_argument("--scene", default="")
    parser.add_argument("--soft", action="store_true")
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--turn", type=float, default=0.0,
                        help="fps: degrees the camera turns each frame, -180 to 180 "
                             "(default: still)")
    parser.add_argument("--method", default=None, choices=registry.MAP_METHODS,
                        help="fps: the hard-shadow method (default: the window's)")
    parser.add_argument("--as-shown", action="store_true",
                        help="fps: with the overlay and FXAA, as play opens the window")
    parser.add_argument("--points", type=int, default=still_lookups.REFINE_POINTS,
                        help="refine: the points a still view's refining ends at")
    parser.add_argument("--every", type=int, default=1,
                        help="refine: measure the visibility every this many frames")
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    args = parser.parse_args(argv)
    if min(args.frames, args.points, args.every) < 1:
        parser.error("--frames, --points and --every must be at least 1")
    if not -180.0 <= args.turn <= 180.0:   # NaN fails this too
        parser.error(f"--turn must be within -180 to 180 degrees, got {args.turn}")
    try:
        if args.mode == "fps":
            doc = fps(args.scene, args.soft, args.frames, args.turn, args.method, args.as_shown)
        elif args.mode == "refine":
            doc = refine(args.scene, args.points, args.frames, args.every)
        else:
            doc = shots(args.scene, args.out)
    except GameError as exc:
        print(f"soft_window: {exc}", file=sys.stderr)
        return 1
    print(json.dumps(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
