"""What each subcommand does, once its arguments are parsed.

Failures are raised as :class:`~game.errors.GameError` (exit 1) or
:class:`~game.cli.arguments.ArgumentError` (exit 2) and printed by :func:`game.cli.main` as one
line.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

from game.cli.arguments import check_as_flag, shadow_settings, trace_settings
from game.cli.checks import check_file as _check_file
from game.cli.checks import check_out as _check_out
from game.cli.checks import command_line as _command_line
from game.cli.checks import say
from game.cli.sweep_commands import (
    accuracy_suite,
    cmd_scenes,
    given_flags,
    refuse_accuracy_flags,
)
from game.cli.values import DEFAULT_OUT, MAX_SCENE_TIME, MAX_SIZE, ArgumentError
from game.errors import GameError
from game.render.depth_first import DepthFirst
from game.shadows import registry
from game.shadows.method import VISIBILITY_TRACED

DEFAULT_BENCH_SIZE = (320, 180)  # the sweep's and the suites' frames, where --size is not given


def cmd_play(args) -> int:
    from game.app.window import walkaround as window

    _check_file("--screenshot", args.screenshot)
    _check_file("--stats", args.stats)
    if args.screenshot is not None and args.frames is None:
        raise ArgumentError("--screenshot needs --frames (F12 saves screenshots interactively)")
    scene = _load(args.scene)
    if args.soft and scene.linear_light is None:
        raise GameError(f"--soft: {args.scene or 'the built-in scene'} has no [linear_light]")
    opts = window.PlayOptions(
        size=args.size, frames=args.frames, screenshot=args.screenshot, stats=args.stats,
        time_step=None if args.fps is None else 1.0 / args.fps, overlay=not args.no_overlay,
        panel=args.panel,
        clock=args.clock, platform=args.platform, settings=shadow_settings(args),
        debug_view=args.debug_view, render_scale=args.render_scale, soft=args.soft,
        cull=not args.no_cull, depth_first=DepthFirst(args.depth_first),
        antialias=args.aa == "fxaa")
    stats = window.play(scene, opts)
    for note in stats["notes"]:
        say(f"note: {note}", err=True)
    if args.frames is not None:
        say(f"played {len(stats['frames'])} frame(s): {window.summary(stats)}")
    return 0


def cmd_trace(args) -> int:
    from game.app import trace as trace_run
    from game.gpu import context

    _check_out(args.out)
    _check_file("--stats", args.stats)
    _check_times(args)
    settings = trace_settings(args)
    scene = _load(args.scene)
    out = _out_folder(args.out, scene)
    _check_out(out, "output folder")
    if scene.linear_light is None:
        raise GameError(f"{args.scene or 'the built-in scene'}: has no [linear_light] to trace")
    ctx = context.create_headless()
    try:
        opts = trace_run.TraceOptions(
            out=out, frames=args.frames, size=args.size, time=args.time, fps=args.fps,
            dump=args.dump, stats=args.stats, clock=args.clock, settings=settings)
        stats = trace_run.run(ctx, scene, opts)
    finally:
        ctx.release()
    cut = sum(f["truncated_points"] for f in stats["frames"])
    if cut:
        say(f"warning: {cut} point(s) ran out of the GL driver's loop budget even at the "
            "smallest step budget per dispatch; their visibility is incomplete", err=True)
    say(f"wrote {args.frames} frame(s) to {out}/: {trace_run.summary(stats)}")
    return 0


def _bench_params(texts: list[str], methods: list[str] | None) -> dict[str, tuple]:
    """The values of each ``--param KEY=V1,V2`` (``texts``), each within the bounds of
    ``capture``'s flag of the same name, and read by one of ``methods`` (None: any)."""
    from game.bench import runs

    params: dict[str, tuple] = {}
    for text in texts:
        try:
            key, swept = runs.parse_param(text)
            for value in swept:
                check_as_flag("capture", key, value)
        except (ValueError, ArgumentError) as exc:
            raise ArgumentError(f"--param {exc}") from None
        params[key] = tuple(dict.fromkeys(params.get(key, ()) + swept))
        readers = [m for m in methods or registry.MAP_METHODS
                   if key in registry.METHODS[m].parameters]
        if not readers:
            raise ArgumentError(f"--param {key}: no selected method reads it")
    return params


def cmd_bench(args) -> int:
    from game.bench import runner as bench
    from game.bench import runs

    if args.suite == "accuracy" and args.report is None:
        return accuracy_suite(args)
    refuse_accuracy_flags(args, f"--suite {args.suite}" if args.suite else
                          "--report" if args.report is not None else "the sweep")
    if args.suite == "window":
        return _window_suite(args)
    args.size = args.size or DEFAULT_BENCH_SIZE
    if args.report is not None:
        return _report(args)
    if args.suite == "gpu":
        return _gpu_suite(args)
    if args.suite == "cache":
        return _cache_suite(args)
    args.out = args.out or Path("bench")
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
    for flag, value in (("--scenes", args.scenes), ("--methods", args.methods)):
        if value is not None and not value.strip():  # else the whole default sweep ran
            raise ArgumentError(f"{flag}: empty; leave the flag out for the default sweep")
    methods = args.methods.split(",") if args.methods else None
    for m in methods or []:
        if m not in registry.MAP_METHODS:
            raise ArgumentError(f"--methods: unknown method {m!r}; valid: "
                                f"{', '.join(registry.MAP_METHODS)}")
    keys = [s.key for s in runs.bench_scenes(quick)]
    patterns, files = [], []
    for entry in args.scenes.split(",") if args.scenes else []:
        if entry.endswith(".toml") or os.sep in entry or Path(entry).is_file():
            files.append(runs.user_scene(Path(entry), keys + [f.key for f in files]))
        elif any(runs.selected(k, [entry]) for k in keys):
            patterns.append(entry)
        else:
            raise ArgumentError(f"--scenes: {entry!r} matches no scene and is no scene file; "
                                f"built-in: {', '.join(keys)}")
    params = _bench_params(args.param, methods)
    # What the bench tells along the way goes to standard output: standard error holds only
    # what went wrong, so that a stopped or failed bench says so in one line there.
    opts = runs.BenchOptions(
        out=args.out, quick=quick, size=args.size, repeat=args.repeat,
        scenes=patterns or None, user_scenes=files, methods=methods, params=params,
        progress=not args.no_progress, clock=args.clock, log=say, **values)
    if args.list:
        for _scene, spec in runs.plan_runs(opts, MAX_SIZE):
            say(spec.run_id(opts.size))
        return 0
    bench.check_outputs(args.out)
    opts.reference = bench.reference_available()
    if not opts.reference:
        say("note: embreex missing: no shadow error or reference flicker "
            "(pip install -e '.[bench]')", err=True)
    result = bench.run(opts, command=_command_line())
    say(f"bench: {result['rows']} rows in {result['csv']}; "
        f"{len(result['charts'])} chart files in {args.out / 'charts'}")
    for c in result["summary"].get("comparisons", []):
        say(f"  {c['scene']}: clumped {c['clumped_ms']:.1f} ms, error "
            f"{100 * c['clumped_error']:.2f}% vs {c['baseline']}: {c['baseline_ms']:.1f} ms, "
            f"{100 * c['baseline_error']:.2f}% -> {c['speedup']:.1f}x")
    if result["failed"]:  # every other run was made, and its row and charts written
        raise GameError(bench.failure_line(result))
    return 0


def _report(args) -> int:
    from game.bench import report

    given = [flag for flag, value in (("--scenes", args.scenes), ("--methods", args.methods),
                                      ("--param", args.param), ("--list", args.list),
                                      ("--out", args.out), ("--quick", args.quick),
                                      ("--suite", args.suite))
             if value]
    if given:
        raise ArgumentError(f"--report measures nothing: it takes no {', '.join(given)}")
    written = report.write_report(args.report)
    say(f"bench --report: wrote {' and '.join(str(p) for p in written)}")
    return 0


def _refuse_sweep_flags(args, what: str, extra: tuple[str, ...] | list[str] = ()) -> None:
    """A suite of its own takes none of the sweep's choices: one line naming those given,
    with the ``extra`` flags given that the suite also refuses."""
    given = [flag for flag, value in (("--scenes", args.scenes), ("--methods", args.methods),
                                      ("--param", args.param), ("--list", args.list),
                                      ("--frames", args.frames), ("--repeat", args.repeat > 1))
             if value] + list(extra)
    if given:
        raise ArgumentError(f"{what}; {', '.join(given)} belong{'s' if len(given) == 1 else ''} "
                            "to the sweep")


def _gpu_suite(args) -> int:
    from game.bench import gpu_suite, runner

    _refuse_sweep_flags(args, "--suite gpu runs a fixed set of checks")
    out = args.out or Path("bench_gpu")
    _check_out(out)
    runner.check_suite_outputs(out)
    summary = gpu_suite.run(gpu_suite.Suite(out=out, quick=args.quick,
                                            progress=not args.no_progress, log=say))
    done = [p["part"] for p in summary["parts"] if p["status"] == "ok"]
    say(f"bench --suite gpu: {', '.join(done) or 'nothing'} done in {summary['wall_s']} s; "
        f"{out / 'summary.md'}")
    return 0


def _cache_suite(args) -> int:
    from game.bench import cache_suite

    _refuse_sweep_flags(args, "--suite cache measures a fixed set")
    out = args.out or Path("bench_cache")
    _check_out(out)
    suite = cache_suite.CacheSuite(out=out, quick=args.quick, log=lambda line: say(line, err=True))
    summary = cache_suite.run(suite, command=_command_line())
    say(f"bench --suite cache: {summary['rows']} rows in {summary['csv']} in "
        f"{summary['wall_s']} s" + "".join(f"; {n}" for n in summary["notes"]))
    return 0


def _window_suite(args) -> int:
    from game.app import outputs
    from game.bench import window_suite as ws

    if args.report is not None:
        raise ArgumentError("--suite window measures; --report writes the page from recorded "
                            "runs: give one or the other")
    given = given_flags(args, ("--warmup", "--error-frames", "--flicker-frames"))
    given += [flag for flag, value in (("--size", args.size), ("--clock", args.clock != "auto"))
              if value]
    _refuse_sweep_flags(args, "--suite window measures the window as play opens it", given)
    out = args.out or Path("bench_window")
    _check_out(out)
    outputs.check_paths(files=[out / "window.csv", out / "run.json"])
    suite = ws.WindowSuite(out=out, frames=ws.QUICK_FRAMES if args.quick else ws.FRAMES,
                           rounds=ws.QUICK_ROUNDS if args.quick else ws.ROUNDS)
    path = ws.run_suite(suite, _command_line(), say=lambda line: say(line, err=True))
    say(f"bench --suite window: wrote {path} and {out / 'run.json'}")
    return 0


def _load(scene_arg: str | None):
    from game.scene import default_scene_path, load_scene

    return load_scene(Path(scene_arg) if scene_arg else default_scene_path())


def _check_times(args) -> None:
    """The last frame's scene time stays within --time's own bounds."""
    last = args.time + (args.frames - 1) / args.fps
    if abs(last) > MAX_SCENE_TIME:
        raise ArgumentError(f"--frames {args.frames} at --fps {args.fps:g} from --time "
                            f"{args.time:g} ends at {last:.3g} s; at most {MAX_SCENE_TIME:g} s")


def _out_folder(out: Path | None, scene) -> Path:
    """``--out``, else captures/<scene name>/: runs of different scenes never mix."""
    return out if out is not None else DEFAULT_OUT / scene.folder_name


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
    _check_file("--stats", args.stats)
    _check_times(args)
    scene = _load(args.scene)
    out = _out_folder(args.out, scene)
    _check_out(out, "output folder")
    ctx = context.create_headless()
    try:
        opts = capture.CaptureOptions(
            out=out, frames=args.frames, size=args.size, time=args.time, fps=args.fps,
            dump=args.dump, stats=args.stats, debug_view=args.debug_view, clock=args.clock,
            overlay=args.overlay, settings=shadow_settings(args), soft=_soft_settings(args, scene),
            cull=not args.no_cull, depth_first=DepthFirst(args.depth_first))
        stats = capture.run(ctx, scene, opts)
    finally:
        ctx.release()
    for note in stats["notes"]:
        say(f"note: {note}", err=True)
    say(f"wrote {args.frames} frame(s) to {out}/: {capture.summary(stats)}")
    return 0


def cmd_verify(args) -> int:
    """Score every dumped frame against Embree (game/app/verify_report.py): the hard ``lit``
    and ``lit_lights`` of a capture, the ``soft`` of a trace; ``--images`` draws the errors."""
    from game.app import outputs, verify_report

    if not args.dumps.exists():
        raise ArgumentError(f"{args.dumps}: no such folder (the folder of a capture --dump)")
    if not args.dumps.is_dir():
        raise ArgumentError(f"{args.dumps}: not a folder (the folder of a capture --dump)")
    frames = sorted(args.dumps.glob("frame_*.npz"))
    if not frames:
        raise ArgumentError(f"{args.dumps}: no frame_*.npz dumps (capture with --dump)")
    _check_file("--out", args.out)
    verify_report.check_dump_files(args.dumps, frames)
    try:
        scene = _scene_of_dumps(args.dumps, frames, args.scene)
        if args.images:  # every picture's path, before any work
            try:
                outputs.check_paths(verify_report.picture_paths(frames, scene))
            except GameError as exc:
                raise ArgumentError(f"--images: {exc}") from None
        results = verify_report.verify_frames(frames, scene, args.images, say)
    except GameError:
        raise  # a failed write (an OSError too) names its file
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise GameError(f"{args.dumps}: cannot read the dumps ({exc})") from None
    except MemoryError:
        raise GameError(f"{args.dumps}: the dumps are too large for this machine's memory") \
            from None
    except RuntimeError as exc:  # Embree missing
        raise GameError(str(exc)) from None
    if args.out is not None:
        outputs.write_json(args.out, {"dumps": str(args.dumps),
                                      "scene": scene.given,
                                      "scene_sha256": scene.sha256, "frames": results})
    return 0


def _scene_of_dumps(folder: Path, frames: list[Path], scene_arg: str | None):
    """The scene the dumps were captured from: ``SCENE`` if it is that scene, else the one the
    dumps record (hashed first, and parsed only if its bytes hash to the recorded hash)."""
    from game.reference.score import file_with_hash, recorded_scene
    from game.scene import parse_scene
    from game.scene.loader import MAX_SCENE_BYTES

    records = [recorded_scene(npz) for npz in frames]
    recorded = {r[:2] for r in records if r is not None}
    if len(recorded) > 1:
        raise GameError(f"{folder}: the dumps come from {len(recorded)} different scenes; "
                        "verify one capture at a time")
    unrecorded = sum(r is None for r in records)
    if scene_arg is not None:
        scene = _load(scene_arg)
        if recorded and next(iter(recorded))[1] != scene.sha256:
            name, sha = next(iter(recorded))
            raise GameError(f"{scene_arg}: not the scene these dumps were captured from (they "
                            f"record {name!r} with sha256 {sha[:12]}...)")
        return scene
    if unrecorded:
        raise GameError(f"{folder}: {unrecorded} of the dumps do not record their scene; name "
                        f"it: python -m game verify {folder} SCENE")
    name, sha, absolute = next(r for r in records if r is not None)
    # A dump may name any file (/etc/passwd): only the very bytes that were captured are parsed.
    candidates = [Path(p) for p in (absolute, name) if p]
    found = file_with_hash(candidates, sha, MAX_SCENE_BYTES)
    there = [p for p in candidates if p.exists()]
    if found is None and not there:
        raise GameError(f"{folder}: the recorded scene {name!r} is not found from here; "
                        f"name it: python -m game verify {folder} SCENE")
    if found is None:
        raise GameError(f"{there[0]}: not the file these dumps were captured from (it does not "
                        f"match the recorded sha256 {sha[:12]}...: changed since, or another "
                        f"file); name the scene: python -m game verify {folder} SCENE")
    path, data = found  # UTF-8: the capture parsed these very bytes
    return parse_scene(data.decode("utf-8", "replace"), source=path, base_dir=path.parent)


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
    out = _out_folder(None, scene)
    _check_out(out, "output folder")
    ctx = context.create_headless()
    try:
        opts = capture.CaptureOptions(out=out, frames=1, size=(960, 540))
        capture.run(ctx, scene, opts)
    finally:
        ctx.release()
    reason = ("no display" if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
              else "cannot open a window on this display")
    say(f"{reason} for the walkaround window: rendered {default_scene_path().name} headless "
        f"to {out}/frame_0000.png (see python -m game capture --help)")
    return 0


COMMANDS = {"play": cmd_play, "capture": cmd_capture, "trace": cmd_trace, "bench": cmd_bench,
            "verify": cmd_verify, "scenes": cmd_scenes}


