"""What each subcommand does, once its arguments are parsed.

Failures are raised as :class:`~game.errors.GameError` (exit 1) or
:class:`~game.cli.arguments.ArgumentError` (exit 2) and printed by :func:`game.cli.main` as one
line.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from game.cli.arguments import (
    DEFAULT_OUT,
    MAX_SIZE,
    ArgumentError,
    shadow_settings,
    trace_settings,
)
from game.errors import GameError
from game.shadows import registry
from game.shadows.method import VISIBILITY_TRACED


def cmd_play(args) -> int:
    from game.app.window import walkaround as window

    for flag, path in (("--screenshot", args.screenshot), ("--stats", args.stats)):
        if path is not None and (path.is_dir() or not path.parent.is_dir()):
            raise ArgumentError(f"{flag} {path}: not a file in an existing folder")
    if args.screenshot is not None and args.frames is None:
        raise ArgumentError("--screenshot needs --frames (F12 saves screenshots interactively)")
    scene = _load(args.scene)
    if args.soft and scene.linear_light is None:
        raise GameError(f"--soft: {args.scene or 'the built-in scene'} has no [linear_light]")
    opts = window.PlayOptions(
        size=args.size, frames=args.frames, screenshot=args.screenshot, stats=args.stats,
        time_step=None if args.fps is None else 1.0 / args.fps, overlay=not args.no_overlay,
        clock=args.clock, platform=args.platform, settings=shadow_settings(args),
        debug_view=args.debug_view, render_scale=args.render_scale, soft=args.soft,
        cull=not args.no_cull)
    stats = window.play(scene, opts)
    if args.frames is not None:
        print(f"played {len(stats['frames'])} frame(s): {window.summary(stats)}")
    return 0


def cmd_trace(args) -> int:
    from game.app import trace as trace_run
    from game.gpu import context

    _check_out(args.out)
    if args.stats is not None and args.stats.is_dir():
        raise ArgumentError(f"--stats {args.stats}: is a folder")
    settings = trace_settings(args)
    scene = _load(args.scene)
    if scene.linear_light is None:
        raise GameError(f"{args.scene or 'the built-in scene'}: has no [linear_light] to trace")
    ctx = context.create_headless()
    try:
        opts = trace_run.TraceOptions(
            out=args.out, frames=args.frames, size=args.size, time=args.time, fps=args.fps,
            dump=args.dump, stats=args.stats, clock=args.clock, settings=settings)
        stats = trace_run.run(ctx, scene, opts)
    finally:
        ctx.release()
    cut = sum(f["truncated_points"] for f in stats["frames"])
    if cut:
        print(f"warning: {cut} point(s) ran out of the GL driver's loop budget even at one "
              "sample per dispatch; their visibility is incomplete", file=sys.stderr)
    print(f"wrote {args.frames} frame(s) to {args.out}/: {trace_run.summary(stats)}")
    return 0


def cmd_bench(args) -> int:
    from game.bench import runner as bench
    from game.bench import runs

    _check_out(args.out)
    quick = args.quick
    counts = {"frames": (8, 4), "warmup": (2, 1), "error_frames": (2, 1),
              "flicker_frames": (3, 2)}
    values = {}
    for name, (full, short) in counts.items():
        value = getattr(args, name)
        if value is not None and value < 0:
            raise ArgumentError(f"--{name.replace('_', '-')}: must be zero or more, got {value}")
        values[name] = (short if quick else full) if value is None else value
    methods = args.methods.split(",") if args.methods else None
    for m in methods or []:
        if m not in registry.MAP_METHODS:
            raise ArgumentError(f"--methods: unknown method {m!r}; valid: "
                                f"{', '.join(registry.MAP_METHODS)}")
    if args.scenes:
        keys = [s.key for s in runs.bench_scenes(quick)]
        for pattern in args.scenes.split(","):
            if not any(runs.selected(k, [pattern]) for k in keys):
                raise ArgumentError(f"--scenes: {pattern!r} matches no scene; valid: "
                                    f"{', '.join(keys)}")
    opts = runs.BenchOptions(
        out=args.out, quick=quick, size=args.size, repeat=args.repeat,
        scenes=args.scenes.split(",") if args.scenes else None, methods=methods,
        progress=not args.no_progress, **values)
    if args.list:
        for _scene, spec in runs.plan_runs(opts, MAX_SIZE):
            print(spec.run_id(opts.size))
        return 0
    try:
        import embreex  # noqa: F401 - only to learn whether the reference can run
    except ImportError:
        opts.reference = False
        print("note: embreex missing: no shadow error or reference flicker "
              "(pip install -e '.[bench]')", file=sys.stderr)
    result = bench.run(opts)
    print(f"bench: {result['rows']} rows in {result['csv']}; "
          f"{len(result['charts'])} chart files in {args.out / 'charts'}")
    for c in result["summary"].get("comparisons", []):
        print(f"  {c['scene']}: clumped {c['clumped_ms']:.1f} ms, error "
              f"{100 * c['clumped_error']:.2f}% vs {c['baseline']}: {c['baseline_ms']:.1f} ms, "
              f"{100 * c['baseline_error']:.2f}% -> {c['speedup']:.1f}x")
    return 0


def _load(scene_arg: str | None):
    from game.scene import default_scene_path, load_scene

    return load_scene(Path(scene_arg) if scene_arg else default_scene_path())


def _check_out(path: Path) -> None:
    if path.exists() and not path.is_dir():
        raise ArgumentError(f"--out {path}: exists and is not a folder")


def _soft_settings(args, scene):
    """capture --soft: the tracer's defaults; a scene without a linear light is an error."""
    if not args.soft:
        return None
    from game.soft.methods import TraceSettings

    if scene.linear_light is None:
        raise GameError(f"--soft: {args.scene or 'the built-in scene'} has no [linear_light]")
    return TraceSettings()


def cmd_capture(args) -> int:
    from game.app import capture
    from game.gpu import context

    traced = registry.METHODS[args.method].visibility == VISIBILITY_TRACED
    if args.debug_view != "none" and (traced or args.soft):
        raise ArgumentError(f"--debug-view {args.debug_view}: shows the shadow maps, and "
                            f"{'--soft' if args.soft else '--method traced'} frames are shaded "
                            "by the tracer instead")
    _check_out(args.out)
    if args.stats is not None and args.stats.is_dir():
        raise ArgumentError(f"--stats {args.stats}: is a folder")
    scene = _load(args.scene)
    ctx = context.create_headless()
    try:
        opts = capture.CaptureOptions(
            out=args.out, frames=args.frames, size=args.size, time=args.time, fps=args.fps,
            dump=args.dump, stats=args.stats, debug_view=args.debug_view, clock=args.clock,
            overlay=args.overlay, settings=shadow_settings(args), soft=_soft_settings(args, scene),
            cull=not args.no_cull)
        stats = capture.run(ctx, scene, opts)
    finally:
        ctx.release()
    for note in stats["notes"]:
        print(f"note: {note}", file=sys.stderr)
    print(f"wrote {args.frames} frame(s) to {args.out}/: {capture.summary(stats)}")
    return 0


def cmd_verify(args) -> int:
    """Score every dumped frame's ``lit`` against Embree shadow rays (game/reference/)."""
    from game.app import outputs
    from game.reference.hard import MIN_NDOTL
    from game.reference.score import score_dump

    frames = sorted(args.dumps.glob("frame_*.npz")) if args.dumps.is_dir() else []
    if not frames:
        raise ArgumentError(f"{args.dumps}: no frame_*.npz dumps (capture with --dump)")
    light = _load(args.scene).light
    try:
        results = []
        for npz in frames:
            err = score_dump(npz, light)
            results.append({"frame": npz.stem, **{k: v for k, v in err.items()
                                                  if k not in ("mask", "exact")}})
            print(f"{npz.stem}: error {err['error']:.4f} ({err['misclassified']} misclassified "
                  f"of {err['shadowed']} shadowed, {err['considered']} pixels with N.L > "
                  f"{MIN_NDOTL})")
    except (OSError, KeyError, ValueError) as exc:
        raise GameError(f"{args.dumps}: cannot read the dumps ({exc})") from None
    except RuntimeError as exc:  # Embree missing
        raise GameError(str(exc)) from None
    if args.out is not None:
        outputs.write_json(args.out, {"dumps": str(args.dumps), "frames": results})
    return 0


def cmd_default() -> int:
    """``python -m game``: the walkaround; with no display, one headless frame and a line."""
    from game.app import capture
    from game.app.window import glfw_setup
    from game.app.window import walkaround as window
    from game.gpu import context
    from game.scene import default_scene_path

    scene = _load(None)
    if glfw_setup.display_available():
        window.play(scene, window.PlayOptions())
        return 0
    out = DEFAULT_OUT / "default"
    ctx = context.create_headless()
    try:
        opts = capture.CaptureOptions(out=out, frames=1, size=(960, 540))
        capture.run(ctx, scene, opts)
    finally:
        ctx.release()
    reason = ("no display" if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
              else "cannot open a window on this display")
    print(f"{reason} for the walkaround window: rendered {default_scene_path().name} headless "
          f"to {out}/frame_0000.png (see python -m game capture --help)")
    return 0


COMMANDS = {"play": cmd_play, "capture": cmd_capture, "trace": cmd_trace, "bench": cmd_bench,
            "verify": cmd_verify}


