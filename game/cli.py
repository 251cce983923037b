"""The command line (CONTRACT.md section 2): parse, run, and turn every failure into one line.

Exit status: 0 success; 1 a bad scene or a machine that cannot run it; 2 a bad argument;
130 interrupted. Set SHADOWGAME_DEBUG=1 to see the traceback of an internal error.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import warnings
from pathlib import Path

from game.app import interrupts
from game.errors import GameError
from game.shadows.methods import clumped as shadow_methods

CAPTURE_METHODS = ("clumped", "single", "static-dynamic", "csm", "traced")
TRACE_METHODS = ("brute", "grid", "tri-cache", "voxel-cache", "analytic")
MAX_SIZE = 16384
DEFAULT_OUT = Path("captures")


class ArgumentError(GameError):
    """A bad command-line value."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line instead of usage plus message."""

    def error(self, message: str):
        if message.endswith("expected one argument"):
            # argparse reads a value such as -5x10 as an option and reports the value missing.
            message += " (write a value that starts with '-' as --option=VALUE)"
        raise ArgumentError(f"{self.prog}: {message}")


def _size(text: str) -> tuple[int, int]:
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WxH, like 960x540, got {text!r}") from None
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise argparse.ArgumentTypeError(f"size must be 1..{MAX_SIZE} per side, got {text!r}")
    return w, h


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def _positive(text: str) -> float:
    value = _finite(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def _non_negative(text: str) -> float:
    value = _finite(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be zero or more, got {text!r}")
    return value


def _unit(text: str) -> float:
    value = _finite(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {text!r}")
    return value


def _add_shadow_options(p: argparse.ArgumentParser) -> None:
    d = shadow_methods.ShadowSettings()
    g = p.add_argument_group("hard-shadow parameters")
    g.add_argument("--clumping", choices=shadow_methods.CLUMPINGS, default=d.clumping,
                   help="group statics by neighbourhood in world space or in light space")
    g.add_argument("--clumps", type=_positive_int, default=None, metavar="N",
                   help="number of clumps (default: from --texels-per-metre)")
    g.add_argument("--texels-per-metre", type=_positive, default=d.texels_per_metre,
                   help="texel-density target that sets the number of clumps")
    g.add_argument("--clump-resolution", type=_positive_int, default=d.clump_resolution,
                   help="texels per side of each clump map")
    g.add_argument("--character-resolution", type=_positive_int,
                   default=d.character_resolution, help="texels per side of each character map")
    g.add_argument("--single-resolution", type=_positive_int, default=d.single_resolution,
                   help="texels per side of the single baseline map")
    g.add_argument("--cascades", type=_positive_int, default=d.cascades,
                   help="csm: number of cascades")
    g.add_argument("--cascade-lambda", type=_unit, default=d.cascade_lambda,
                   help="csm: split blend, 1 logarithmic, 0 uniform")
    g.add_argument("--cascade-resolution", type=_positive_int, default=d.cascade_resolution,
                   help="csm: texels per side of each cascade")
    g.add_argument("--normal-bias", type=_non_negative, default=d.normal_bias,
                   help="normal offset in texels")
    g.add_argument("--depth-bias", type=_non_negative, default=d.depth_bias,
                   help="constant depth bias in texels")
    g.add_argument("--slope-bias", type=_non_negative, default=d.slope_bias,
                   help="slope-scaled depth bias in texels")
    g.add_argument("--pcf", action="store_true", help="3x3 percentage-closer filtering")
    g.add_argument("--grid", choices=("auto", "on", "off"), default=d.grid,
                   help="light-space grid of map lists (auto: when there are many maps)")
    g.add_argument("--debug-view", choices=("none", "map", "map-count", "cache"),
                   default="none",
                   help="colour pixels by the map they used, by the number of maps read, or "
                        "by whether their map was re-rendered (red) or cached (green)")
    g.add_argument("--clock", choices=("auto", "cpu-finish", "gpu-query"), default="auto",
                   help="timing clock (auto: CPU around glFinish on llvmpipe, GPU queries "
                        "elsewhere)")


def _settings(args) -> shadow_methods.ShadowSettings:
    return shadow_methods.ShadowSettings(
        method=args.method, clumping=args.clumping, clump_count=args.clumps,
        texels_per_metre=args.texels_per_metre, clump_resolution=args.clump_resolution,
        character_resolution=args.character_resolution,
        single_resolution=args.single_resolution, normal_bias=args.normal_bias,
        depth_bias=args.depth_bias, slope_bias=args.slope_bias, pcf=args.pcf, grid=args.grid,
        cascades=args.cascades, cascade_lambda=args.cascade_lambda,
        cascade_resolution=args.cascade_resolution)


# -- play (the walkaround window, issue 5) -------------------------------------------------
def _render_scale(text: str) -> float:
    value = _finite(text)
    if not 0.25 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be 0.25..1, got {text!r}")
    return value


def _add_play_parser(sub) -> None:
    play = sub.add_parser(
        "play", help="the walkaround window",
        description="WASD move, right mouse button (or Tab) looks, Shift faster, Q/E down/up, "
                    "R resets the view, P pauses the characters, M next method, F12 screenshot, "
                    "Esc quits. See docs/window.md.")
    play.add_argument("scene", nargs="?", help="scene file (default: the built-in scene)")
    play.add_argument("--frames", type=_positive_int, help="quit by itself after N frames")
    play.add_argument("--screenshot", type=Path, metavar="FILE",
                      help="save the last frame as the window shows it, overlay included")
    play.add_argument("--stats", type=Path, metavar="FILE",
                      help="write per-frame stats JSON and the frame rate")
    play.add_argument("--size", type=_size, default=(960, 540), metavar="WxH",
                      help="window size in pixels")
    play.add_argument("--method", choices=CAPTURE_METHODS, default="clumped")
    play.add_argument("--fps", type=_positive, default=None,
                      help="scene seconds advance 1/F per frame (default: real time)")
    play.add_argument("--render-scale", type=_render_scale, default=1.0, metavar="S",
                      help="render the scene at S times the window's size per side, then "
                           "scale it up (0.25..1; llvmpipe is fill-bound)")
    play.add_argument("--no-overlay", action="store_true", help="hide the timing overlay")
    _add_cull_option(play)
    play.add_argument("--soft", action="store_true",
                      help="start with soft shadows of the scene's [linear_light], traced at a "
                           "quarter of the window's size per side (overlay checkbox)")
    play.add_argument("--platform", choices=("auto", "null"), default="auto",
                      help="null: GLFW's null platform, a window with no display (scripts, CI)")
    _add_shadow_options(play)


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
        clock=args.clock, platform=args.platform, settings=_settings(args),
        debug_view=args.debug_view, render_scale=args.render_scale, soft=args.soft,
        cull=not args.no_cull)
    stats = window.play(scene, opts)
    if args.frames is not None:
        print(f"played {len(stats['frames'])} frame(s): {window.summary(stats)}")
    return 0


def _add_cull_option(parser) -> None:
    parser.add_argument("--no-cull", action="store_true",
                        help="draw every triangle in the camera pass, not only those that can "
                             "cover a pixel centre (same pixels; slower where triangles are "
                             "small on screen; game/triangle_cull.py)")


def _add_frame_options(parser, dump_help: str) -> None:
    """Which frames to render and where they go: the same for capture and trace."""
    parser.add_argument("--frames", type=_positive_int, default=1)
    parser.add_argument("--size", type=_size, default=(960, 540), metavar="WxH")
    parser.add_argument("--time", type=_finite, default=0.0,
                        help="scene time of the first frame")
    parser.add_argument("--fps", type=_positive, default=30.0, help="frames per scene second")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR")
    parser.add_argument("--dump", action="store_true", help=dump_help)
    parser.add_argument("--stats", type=Path, metavar="FILE", help="write per-frame stats JSON")


# -- trace (soft shadows of the linear light, issue 4) --------------------------------------
def _add_trace_parser(sub) -> None:
    from game.soft.tracer import TraceSettings

    d = TraceSettings()
    trace = sub.add_parser("trace", help="soft shadows of the linear light (compute pass)")
    trace.add_argument("scene", nargs="?", help="scene file (default: the built-in scene)")
    trace.add_argument("--method", choices=TRACE_METHODS, default="voxel-cache")
    trace.add_argument("--samples", type=_positive_int, default=d.samples, metavar="N",
                       help="stratified samples along the segment per shaded point")
    _add_frame_options(trace, dump_help="write npz (with soft) + glb")
    trace.add_argument("--clock", choices=("auto", "cpu-finish", "gpu-query"), default="auto")
    g = trace.add_argument_group("tracer parameters")
    g.add_argument("--cells-per-triangle", type=_positive, default=d.cells_per_triangle,
                   help="grid resolution: cells per triangle of the scene")
    g.add_argument("--vc-slots", type=_positive_int, default=d.vc_slots,
                   help="voxel-cache: voxels cached per shaded point (a power of two)")
    g.add_argument("--vc-pool", type=_positive_int, default=d.vc_pool,
                   help="voxel-cache: candidate triangle ids cached per shaded point")
    g.add_argument("--mailbox", type=_positive_int, default=d.mailbox,
                   help="triangles remembered per ray (mailboxing)")


def _trace_settings(args):
    from game.soft.tracer import TraceSettings

    if args.vc_slots & (args.vc_slots - 1):
        raise ArgumentError(f"--vc-slots {args.vc_slots}: must be a power of two")
    return TraceSettings(method=args.method, samples=args.samples,
                         cells_per_triangle=args.cells_per_triangle, vc_slots=args.vc_slots,
                         vc_pool=args.vc_pool, mailbox=args.mailbox)


def cmd_trace(args) -> int:
    from game.app import trace as trace_run
    from game.gpu import context

    _check_out(args.out)
    if args.stats is not None and args.stats.is_dir():
        raise ArgumentError(f"--stats {args.stats}: is a folder")
    settings = _trace_settings(args)
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


# -- bench (speed-versus-accuracy sweeps, issue 3) ------------------------------------------
def _add_bench_parser(sub) -> None:
    bench = sub.add_parser(
        "bench", help="speed-versus-accuracy sweeps and charts",
        description="Sweep methods x parameters x scenes along a fixed camera path; write "
                    "OUT/bench.csv (one row per run; finished rows are kept and skipped on a "
                    "rerun), OUT/charts/*.png|svg and OUT/summary.json. See docs/results.md.")
    bench.add_argument("--quick", action="store_true",
                       help="the short sweep (default scene, a small town, stability scenes)")
    bench.add_argument("--out", type=Path, default=Path("bench"), metavar="DIR")
    bench.add_argument("--size", type=_size, default=(320, 180), metavar="WxH")
    bench.add_argument("--frames", type=_positive_int, default=None,
                       help="timed frames per run (default 8, quick 4)")
    bench.add_argument("--warmup", type=int, default=None,
                       help="frames before timing (default 2, quick 1)")
    bench.add_argument("--error-frames", type=int, default=None,
                       help="frames scored against Embree per run (default 2, quick 1)")
    bench.add_argument("--flicker-frames", type=int, default=None,
                       help="frames with only the camera moving, for flicker (default 3, quick 2)")
    bench.add_argument("--repeat", type=_positive_int, default=1,
                       help="time each run N times, round-robin over the scene's runs, and "
                            "keep the median (steadier ratios on a loaded machine)")
    bench.add_argument("--scenes", help="comma-separated scene keys or patterns (town_*)")
    bench.add_argument("--methods", help="comma-separated methods")
    bench.add_argument("--list", action="store_true", help="print the runs and exit")
    bench.add_argument("--no-progress", action="store_true", help="no progress bar")


def cmd_bench(args) -> int:
    from game.bench import runner as bench

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
        if m not in shadow_methods.METHODS:
            raise ArgumentError(f"--methods: unknown method {m!r}; valid: "
                                f"{', '.join(shadow_methods.METHODS)}")
    if args.scenes:
        keys = [s.key for s in bench.bench_scenes(quick)]
        for pattern in args.scenes.split(","):
            if not any(bench.selected(k, [pattern]) for k in keys):
                raise ArgumentError(f"--scenes: {pattern!r} matches no scene; valid: "
                                    f"{', '.join(keys)}")
    opts = bench.BenchOptions(
        out=args.out, quick=quick, size=args.size, repeat=args.repeat,
        scenes=args.scenes.split(",") if args.scenes else None, methods=methods,
        progress=not args.no_progress, **values)
    if args.list:
        for _scene, spec in bench.plan_runs(opts, MAX_SIZE):
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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="python -m game",
                     description="Multi-map hard shadows and linear-light soft shadows.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)

    _add_play_parser(sub)
    cap = sub.add_parser("capture", help="render frames headless through EGL")
    cap.add_argument("scene", nargs="?", help="scene file (default: the built-in scene)")
    cap.add_argument("--method", choices=CAPTURE_METHODS, default="clumped")
    _add_frame_options(cap, dump_help="write npz + glb beside each frame")
    cap.add_argument("--overlay", action="store_true", help="draw the timing overlay")
    _add_cull_option(cap)
    cap.add_argument("--soft", action="store_true",
                     help="light the frames by the linear light, with traced soft shadows "
                          "(voxel-cache, 32 samples; see python -m game trace)")
    _add_shadow_options(cap)

    _add_trace_parser(sub)
    _add_bench_parser(sub)

    verify = sub.add_parser(
        "verify", help="shadow error of dumped frames against Embree shadow rays")
    verify.add_argument("dumps", type=Path, metavar="DIR", help="a capture --dump folder")
    verify.add_argument("scene", nargs="?", help="the scene captured (default: built-in)")
    verify.add_argument("--out", type=Path, metavar="FILE",
                        help="write the per-frame errors as JSON")
    return parser


def _load(scene_arg: str | None):
    from game.scene.loader import default_scene_path, load_scene

    return load_scene(Path(scene_arg) if scene_arg else default_scene_path())


def _check_out(path: Path) -> None:
    if path.exists() and not path.is_dir():
        raise ArgumentError(f"--out {path}: exists and is not a folder")


def _soft_settings(args, scene):
    """capture --soft: the tracer's defaults; a scene without a linear light is an error."""
    if not args.soft:
        return None
    from game.soft.tracer import TraceSettings

    if scene.linear_light is None:
        raise GameError(f"--soft: {args.scene or 'the built-in scene'} has no [linear_light]")
    return TraceSettings()


def cmd_capture(args) -> int:
    from game.app import capture
    from game.gpu import context

    if args.debug_view != "none" and (args.method == "traced" or args.soft):
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
            overlay=args.overlay, settings=_settings(args), soft=_soft_settings(args, scene),
            cull=not args.no_cull)
        stats = capture.run(ctx, scene, opts)
    finally:
        ctx.release()
    for note in stats["notes"]:
        print(f"note: {note}", file=sys.stderr)
    print(f"wrote {args.frames} frame(s) to {args.out}/: {capture.summary(stats)}")
    return 0


def cmd_verify(args) -> int:
    """Compare every dumped frame's ``lit`` with Embree shadow rays (game/reference.py)."""
    from game.app import outputs
    from game.reference import hard as reference

    frames = sorted(args.dumps.glob("frame_*.npz")) if args.dumps.is_dir() else []
    if not frames:
        raise ArgumentError(f"{args.dumps}: no frame_*.npz dumps (capture with --dump)")
    light = _load(args.scene).light
    try:
        results = []
        for npz in frames:
            frame = reference.load_frame(npz)
            mesh = reference.load_geometry(npz.with_suffix(".glb"))
            exact = reference.hard_visibility(mesh, frame["position"], frame["normal"], light)
            err = reference.shadow_error(frame["lit"], exact, frame["position"], frame["normal"],
                                         light)
            results.append({"frame": npz.stem, **{k: v for k, v in err.items() if k != "mask"}})
            print(f"{npz.stem}: error {err['error']:.4f} ({err['misclassified']} misclassified "
                  f"of {err['shadowed']} shadowed, {err['considered']} pixels with N.L > "
                  f"{reference.MIN_NDOTL})")
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
    from game.app.window import walkaround as window
    from game.gpu import context
    from game.scene.loader import default_scene_path

    scene = _load(None)
    if window.display_available():
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


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings (a mesh lost degenerate triangles) as one line, without the source line."""
    print(f"warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    warnings.showwarning = _one_line_warning
    interrupts.install()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            return cmd_default()
        return COMMANDS[args.command](args)
    except ArgumentError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except GameError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the one place that turns bugs into one line too
        if interrupts.pending():  # Ctrl-C that a library turned into another exception
            print("interrupted", file=sys.stderr)
            return 130
        if os.environ.get("SHADOWGAME_DEBUG"):
            raise
        first = str(exc).splitlines()[0] if str(exc) else ""
        print(f"internal error: {type(exc).__name__}: {first} (set SHADOWGAME_DEBUG=1 for the "
              "traceback)", file=sys.stderr)
        return 1
