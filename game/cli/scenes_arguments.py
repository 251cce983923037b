"""The ``scenes`` subcommand's parser: scenes written for others to run."""

from __future__ import annotations

from pathlib import Path

from game.cli.bench_arguments import MAX_SEED
from game.cli.values import path_value, whole

DEFAULT_SCENES_OUT = Path("scenes")  # a random scene goes to DEFAULT_SCENES_OUT/random_<seed>/


def add_scenes_parser(sub) -> None:
    scenes = sub.add_parser(
        "scenes", help="write generated scenes",
        description="Write a generated scene as a folder: its scene file and copies of the mesh "
                    "files it names, so that it reads nothing outside the folder.")
    kinds = scenes.add_subparsers(dest="scenes_command", metavar="KIND", required=True,
                                  parser_class=type(scenes))
    random = kinds.add_parser(
        "random", help="a seeded random scene, for accuracy sweeps",
        description="A random scene drawn from --seed: crowds of capsules and real meshes, "
                    "statics of every shape, real props, at times the real corpus's one-file "
                    "level, suns, spot and point lamps, a camera at street level or far above. "
                    "The same seed always writes the same bytes. Needs the real corpus "
                    "(python assets/fetch_real.py).")
    random.add_argument("--seed", type=whole(0, MAX_SEED), required=True, metavar="N",
                        help="the number the scene is drawn from: one number, one scene")
    random.add_argument("--out", type=path_value, default=None, metavar="DIR",
                        help=f"output folder (default: {DEFAULT_SCENES_OUT}/random_<seed>/)")
