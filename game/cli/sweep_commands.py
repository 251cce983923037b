"""The random scenes and the sweep over them: ``scenes random`` and ``bench --suite accuracy``."""

from __future__ import annotations

from pathlib import Path

from game.cli.checks import check_out, command_line, say
from game.cli.scenes_arguments import DEFAULT_SCENES_OUT
from game.cli.values import ArgumentError
from game.errors import GameError

ACCURACY_OUT = Path("bench_accuracy")
# What the accuracy suite does not take, by flag: the main sweep's choices.
NOT_ACCURACY = ("--scenes", "--methods", "--param", "--list", "--quick", "--warmup",
                "--error-frames", "--flicker-frames", "--repeat")
ACCURACY_ONLY = ("--seeds", "--workers", "--cluster")


def cmd_scenes(args) -> int:
    """``scenes random --seed N [--out DIR]``: the scene's folder, written whole."""
    from game.app import outputs
    from game.scene import random_scene

    out = args.out if args.out is not None else DEFAULT_SCENES_OUT / f"random_{args.seed}"
    check_out(out)
    scene = random_scene.draw(args.seed)
    files = random_scene.scene_files(scene)
    outputs.check_paths(files=[out / name for name in files], folders=[out])
    out.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        outputs.write_bytes(out / name, data)
    say(f"wrote {out / scene.file_name}" + (f" and {len(files) - 1} mesh file(s)"
                                             if len(files) > 1 else "")
        + f": {scene.summary}")
    return 0


def given_flags(args, flags) -> list[str]:
    """Which of ``flags`` were given a value other than their default."""
    values = {"--scenes": args.scenes, "--methods": args.methods, "--param": args.param,
              "--list": args.list, "--quick": args.quick, "--warmup": args.warmup is not None,
              "--error-frames": args.error_frames is not None,
              "--flicker-frames": args.flicker_frames is not None, "--repeat": args.repeat > 1,
              "--seeds": args.seeds is not None, "--workers": args.workers > 1,
              "--cluster": args.cluster is not None}
    return [flag for flag in flags if values[flag]]


def refuse_accuracy_flags(args, what: str) -> None:
    """The accuracy suite's own flags, given to anything else: one line naming them."""
    given = given_flags(args, ACCURACY_ONLY)
    if given:
        raise ArgumentError(f"{what} takes no {', '.join(given)}: "
                            f"{'they belong' if len(given) > 1 else 'it belongs'} to --suite "
                            "accuracy")


def accuracy_suite(args) -> int:
    from game.bench import accuracy_suite as suite_module

    given = given_flags(args, NOT_ACCURACY)
    if given:
        raise ArgumentError(f"--suite accuracy runs every map method at its defaults on the "
                            f"random scenes of --seeds; {', '.join(given)} belong to the sweep")
    if args.seeds is None:
        raise ArgumentError("--suite accuracy needs --seeds A..B (or one seed N)")
    if args.workers > 1 and args.cluster is not None:
        raise ArgumentError("--workers and --cluster: give one (the cluster's scheduler spreads "
                            "the runs over its own workers)")
    if args.cluster is not None:
        from game.bench.accuracy_pool import address_problem

        problem = address_problem(args.cluster)
        if problem is not None:
            raise ArgumentError(problem)
    out = args.out or ACCURACY_OUT
    check_out(out)
    suite_module.check_outputs(out)
    suite = suite_module.AccuracySuite(
        out=out, seeds=args.seeds, size=args.size,
        frames=args.frames or suite_module.DEFAULT_FRAMES, workers=args.workers,
        cluster=args.cluster, log=say)
    summary = suite_module.run(suite, command=command_line())
    say(f"bench --suite accuracy: {summary['scenes']} scenes in {summary['csv']} in "
        f"{summary['wall_s']} s; clumped within {summary['targets']['ratio']:g}x + "
        f"{summary['targets']['slack_px']:g} px of the better baseline on "
        f"{summary['within_target']} of {summary['compared']}, over the ceiling on "
        f"{summary['over_ceiling']}; {out / 'summary.md'}")
    if summary["failed"]:
        raise GameError(f"bench --suite accuracy: {len(summary['failed'])} run(s) failed (the "
                        f"first: {summary['failed'][0]}); the status column of "
                        f"{summary['csv']} says why for each")
    return 0
