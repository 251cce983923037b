"""The command line's parser: every subcommand, flag, default and value check.

A bad value becomes one :class:`ArgumentError` line (exit status 2), never argparse's usage
block. The method choices come from the registries (shadows/registry.py, soft/methods.py).
"""

from __future__ import annotations

import argparse
import difflib
import re

from game.cli.bench_arguments import add_bench_parser
from game.cli.scenes_arguments import add_scenes_parser
from game.cli.values import (  # the value types, also for the modules that import them here
    DEFAULT_OUT,
    MAX_SCENE_TIME,
    MAX_SIZE,
    ArgumentError,
    at_most,
    bias_texels,
    finite,
    frame_rate,
    in_range,
    map_side,
    path_value,
    positive,
    positive_int,
    scene_time,
    size_value,
    unit,
    whole,
)
from game.gpu.blocks import DEBUG_VIEWS
from game.gpu.timing import CLOCKS
from game.render.depth_first import DepthFirst
from game.shadows import clumping, registry
from game.shadows.plan import ShadowSettings
from game.soft import methods as trace_methods
from game.soft.grid import STRUCTURES
from game.soft.methods import TraceSettings

__all__ = ["DEFAULT_OUT", "MAX_SCENE_TIME", "MAX_SIZE", "ArgumentError", "Parser", "at_most",
           "bias_texels", "build_parser", "check_as_flag", "finite", "frame_rate", "in_range",
           "map_side", "path_value", "positive", "positive_int", "scene_time",
           "shadow_settings", "size_value", "trace_settings", "unit", "whole"]

CLOCK_HELP = "timing clock (auto: CPU around glFinish on llvmpipe, GPU queries elsewhere)"


def _shown(value) -> str:
    if isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, int) for v in value):
        return f"{value[0]}x{value[1]}"  # a --size
    return str(value)


class HelpFormatter(argparse.HelpFormatter):
    """Each option's help ends with its default, where there is one to show."""

    def _get_help_string(self, action) -> str:
        text, default = action.help or "", action.default
        # The bounds of whole() and in_range(shown=True) come first.
        notes = [getattr(action.type, "bounds", None)]
        if not (not action.option_strings or default in (None, False, argparse.SUPPRESS)
                or "default" in text):
            notes.append("default: " + _shown(default).replace("%", "%%"))
        notes = "; ".join(n for n in notes if n)
        return f"{text} ({notes})" if text and notes else text or notes


LONG_WORD = re.compile(r"\S{201,}")  # longer than any path a user types


class Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line instead of usage plus message, shows
    defaults in ``--help``, and suggests the nearest flag for a mistyped one."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        if message.endswith("expected one argument"):
            # argparse reads a value such as -5x10 as an option and reports the value missing.
            message += " (write a value that starts with '-' as --option=VALUE)"
        # A value thousands of characters long is shown by its ends: the line stays a line.
        message = LONG_WORD.sub(lambda m: f"{m[0][:24]}...{m[0][-8:]} ({len(m[0])} characters)",
                                message)
        raise ArgumentError(f"{self.prog}: {message}")

    def parse_args(self, args=None, namespace=None):
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            parser = self._command_parser(getattr(namespace, "command", None))
            flags = [f for f in parser._option_string_actions if f.startswith("--")]
            hint = ""
            for extra in extras:
                close = difflib.get_close_matches(extra.split("=", 1)[0], flags, n=1)
                if extra.startswith("-") and close:
                    hint = f" (did you mean {close[0]}?)"
                    break
            parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
        return namespace

    def _command_parser(self, command: str | None) -> argparse.ArgumentParser:
        """The subcommand's parser (its flags, its prog in messages), else this one."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction) and command in action.choices:
                return action.choices[command]
        return self




def _add_method_option(parser) -> None:
    """``--method``: the hard-shadow methods of the registry, each with its summary."""
    parser.add_argument("--method", choices=list(registry.METHODS),
                        default=registry.DEFAULT_METHOD,
                        help="; ".join(f"{name}: {cls.summary}"
                                       for name, cls in registry.METHODS.items()))


def _add_shadow_options(p: argparse.ArgumentParser) -> None:
    d = ShadowSettings()
    g = p.add_argument_group("hard-shadow parameters")
    g.add_argument("--clumping", choices=clumping.STRATEGIES, default=d.clumping,
                   help="group statics by neighbourhood in world space or in light space")
    g.add_argument("--clumps", type=positive_int, default=None, metavar="N",
                   help="number of clumps (default: from --texels-per-metre)")
    g.add_argument("--texels-per-metre", type=positive, default=d.texels_per_metre,
                   help="texel-density target that sets the number of clumps")
    g.add_argument("--clump-resolution", type=map_side, default=d.clump_resolution,
                   help="texels per side of each clump map")
    g.add_argument("--character-resolution", type=map_side,
                   default=d.character_resolution,
                   help="most texels per side of a character map")
    g.add_argument("--min-character-resolution", type=map_side,
                   default=d.min_character_resolution,
                   help="fewest texels per side of a character map")
    g.add_argument("--character-texels-per-pixel", type=bias_texels,
                   default=d.character_texels_per_pixel,
                   help="character map texels per pixel where the shadow can be nearest the "
                        "camera; 0 keeps every character map at the most, every frame")
    g.add_argument("--view-resolution", action=argparse.BooleanOptionalAction,
                   default=d.view_resolution,
                   help="clumped: size each clump map by what the view needs (up to "
                        "--max-clump-resolution, in the memory the fixed maps would take), "
                        "instead of --clump-resolution for every clump map")
    g.add_argument("--max-clump-resolution", type=map_side, default=d.max_clump_resolution,
                   help="clumped with --view-resolution: the largest side of a clump map")
    g.add_argument("--single-resolution", type=map_side, default=d.single_resolution,
                   help="texels per side of the single baseline map")
    g.add_argument("--lamp-resolution", type=map_side, default=d.lamp_resolution,
                   help="the smallest side of a baseline's map (or cube face) for a spot or "
                        "point light with a range; lamps whose range spans more of the scene "
                        "get more, up to --single-resolution")
    g.add_argument("--cascades", type=whole(1, 64), default=d.cascades,
                   help="csm: number of cascades")
    g.add_argument("--cascade-lambda", type=unit, default=d.cascade_lambda,
                   help="csm: split blend, 1 logarithmic, 0 uniform")
    g.add_argument("--cascade-resolution", type=map_side, default=d.cascade_resolution,
                   help="csm: texels per side of each cascade")
    g.add_argument("--normal-bias", type=bias_texels, default=d.normal_bias,
                   help="normal offset in texels")
    g.add_argument("--depth-bias", type=bias_texels, default=d.depth_bias,
                   help="constant depth bias in texels")
    g.add_argument("--slope-bias", type=bias_texels, default=d.slope_bias,
                   help="slope-scaled depth bias in texels")
    g.add_argument("--pcf", action=argparse.BooleanOptionalAction, default=None,
                   help="3x3 percentage-closer filtering (default: on in the window, off in "
                        "captures and the benchmark)")
    g.add_argument("--grid", choices=("auto", "on", "off"), default=d.grid,
                   help="light-space grid of map lists (auto: when there are many maps)")
    g.add_argument("--debug-view", choices=list(DEBUG_VIEWS), default="none",
                   help="map: each pixel in the colour of the map that decided it (grey: none); "
                        "map-count: the maps it read, blue 0, cyan 1, green 2, yellow 3, red 4 "
                        "or more; cache: its map drawn this frame (red) or cached (green); "
                        "shadowed-lights: the lights that reach it but are blocked, grey 0, "
                        "blue 1, cyan 2, yellow 3, red 4 or more")
    g.add_argument("--clock", choices=CLOCKS, default="auto", help=CLOCK_HELP)


def check_as_flag(command: str, key: str, value) -> None:
    """Take ``value`` of the setting ``key`` as ``command``'s flag of the same name would
    (``--param`` of bench names the settings that capture's flags set): an ArgumentError with
    that flag's message where it refuses the value, as it would at parse time."""
    flag = "--" + key.replace("_", "-")
    parser = build_parser()._command_parser(command)
    action = next((a for a in parser._actions if flag in a.option_strings), None)
    if action is None or action.type is None or isinstance(value, bool):
        return
    try:
        action.type(str(value))
    except argparse.ArgumentTypeError as exc:
        raise ArgumentError(f"{key}: {exc}") from None


def shadow_settings(args) -> ShadowSettings:
    return ShadowSettings(
        method=args.method, clumping=args.clumping, clump_count=args.clumps,
        texels_per_metre=args.texels_per_metre, clump_resolution=args.clump_resolution,
        character_resolution=args.character_resolution,
        min_character_resolution=args.min_character_resolution,
        character_texels_per_pixel=args.character_texels_per_pixel,
        single_resolution=args.single_resolution, lamp_resolution=args.lamp_resolution,
        view_resolution=args.view_resolution, max_clump_resolution=args.max_clump_resolution,
        normal_bias=args.normal_bias,
        depth_bias=args.depth_bias, slope_bias=args.slope_bias,
        pcf=args.pcf if args.pcf is not None else args.command == "play", grid=args.grid,
        cascades=args.cascades, cascade_lambda=args.cascade_lambda,
        cascade_resolution=args.cascade_resolution)


render_scale = in_range(0.25, 1.0)


def _add_play_parser(sub) -> None:
    play = sub.add_parser(
        "play", help="the walkaround window",
        description="WASD move, right mouse button (or Tab) looks, Shift faster, Q/E down/up, "
                    "R resets the view, P pauses the characters, M next method, F1 overlay panel, "
                    "F12 screenshot, Esc quits. See docs/window.md.")
    play.add_argument("scene", nargs="?", help="scene file (default: the built-in scene)")
    play.add_argument("--frames", type=positive_int, help="quit by itself after N frames")
    play.add_argument("--screenshot", type=path_value, metavar="FILE",
                      help="save the last frame as the window shows it, overlay included")
    play.add_argument("--stats", type=path_value, metavar="FILE",
                      help="write per-frame stats JSON and the frame rate")
    play.add_argument("--size", type=size_value, default=(960, 540), metavar="WxH",
                      help="window size in pixels")
    _add_method_option(play)
    play.add_argument("--fps", type=frame_rate, default=None,
                      help="scene seconds advance 1/F per frame (default: real time)")
    play.add_argument("--render-scale", type=render_scale, default=1.0, metavar="S",
                      help="render the scene at S times the window's size per side, then "
                           "scale it up (0.25..1; llvmpipe is fill-bound)")
    play.add_argument("--no-overlay", action="store_true", help="hide the timing overlay")
    play.add_argument("--panel", action="store_true",
                      help="open with the overlay's full panel rather than its HUD (F1 "
                           "switches)")
    play.add_argument("--aa", choices=("fxaa", "none"), default="fxaa",
                      help="anti-aliasing of the picture shown (FXAA); the scene's own frame "
                           "and its G-buffer are never filtered")
    _add_camera_pass_options(play)
    play.add_argument("--soft", action="store_true",
                      help="start with soft shadows of the scene's [linear_light], traced at a "
                           "quarter of the window's size per side (overlay checkbox)")
    play.add_argument("--platform", choices=("auto", "null"), default="auto",
                      help="null: GLFW's null platform, a window with no display (scripts, CI)")
    _add_shadow_options(play)


def _add_camera_pass_options(parser) -> None:
    parser.add_argument("--no-cull", action="store_true",
                        help="draw every triangle in the camera pass, not only those that can "
                             "cover a pixel centre (same pixels; slower where triangles are "
                             "small on screen; game/render/cull.py)")
    parser.add_argument("--depth-first", choices=[m.value for m in DepthFirst], default="auto",
                        help="draw the camera pass's depth before shading it: auto (default) "
                             "where the last frame shaded more fragments than the picture has "
                             "pixels, on, or off (same pixels; game/render/depth_first.py)")


def _add_frame_options(parser, dump_help: str) -> None:
    """Which frames to render and where they go: the same for capture and trace."""
    parser.add_argument("--frames", type=positive_int, default=1, metavar="N",
                        help="number of frames")
    parser.add_argument("--size", type=size_value, default=(960, 540), metavar="WxH",
                        help="image size in pixels")
    parser.add_argument("--time", type=scene_time, default=0.0, metavar="T",
                        help="scene time of the first frame, in seconds (within +-1e9)")
    parser.add_argument("--fps", type=frame_rate, default=30.0, metavar="F",
                        help="frames per scene second: frame k is at T + k/F (1e-3..1e6)")
    parser.add_argument("--out", type=path_value, default=None, metavar="DIR",
                        help=f"output folder (default: {DEFAULT_OUT}/<scene name>/)")
    parser.add_argument("--dump", action="store_true", help=dump_help)
    parser.add_argument("--stats", type=path_value, metavar="FILE",
                        help="write per-frame stats JSON")


def _add_trace_parser(sub) -> None:
    d = TraceSettings()
    trace = sub.add_parser("trace", help="soft shadows of the linear light (compute pass)")
    trace.add_argument("scene", nargs="?", help="scene file (default: the built-in scene)")
    trace.add_argument("--method", choices=list(trace_methods.METHODS),
                       default=trace_methods.DEFAULT_METHOD,
                       help="; ".join(f"{name}: {m.summary}"
                                      for name, m in trace_methods.METHODS.items()))
    most = trace_methods.LIMITS
    trace.add_argument("--samples", type=at_most(most["samples"]), default=d.samples,
                       metavar="N", help="stratified samples along the segment per shaded point "
                                         f"(at most {most['samples']})")
    _add_frame_options(trace, dump_help="write npz (with soft) + glb")
    trace.add_argument("--clock", choices=CLOCKS, default="auto", help=CLOCK_HELP)
    g = trace.add_argument_group("tracer parameters")
    g.add_argument("--structure", choices=list(STRUCTURES), default=d.structure,
                   help="; ".join(f"{name}: {text}" for name, text in STRUCTURES.items()))
    g.add_argument("--cells-per-triangle", type=at_most(most["cells_per_triangle"], positive),
                   default=d.cells_per_triangle,
                   help="grid resolution: cells per triangle of the scene (at most "
                        f"{most['cells_per_triangle']:g})")
    g.add_argument("--vc-slots", type=at_most(most["vc_slots"]), default=d.vc_slots,
                   help="voxel-cache: voxels cached per shaded point (a power of two, at most "
                        f"{most['vc_slots']})")
    g.add_argument("--vc-pool", type=at_most(most["vc_pool"]), default=d.vc_pool,
                   help="voxel-cache: candidate triangle ids cached per shaded point (at most "
                        f"{most['vc_pool']})")
    g.add_argument("--mailbox", type=at_most(most["mailbox"]), default=d.mailbox,
                   help=f"triangles remembered per ray, mailboxing (at most {most['mailbox']})")
    r = trace.add_argument_group("raster methods' parameters")
    r.add_argument("--maps", type=at_most(most["maps"]), default=d.maps, metavar="K",
                   help=f"segment-maps: depth maps from K points along the segment (at most "
                        f"{most['maps']})")
    r.add_argument("--map-resolution", type=at_most(most["map_resolution"]),
                   default=d.map_resolution, metavar="N",
                   help="segment-maps, pcss: texels per side of each depth map (at most "
                        f"{most['map_resolution']})")


def trace_settings(args) -> TraceSettings:
    if args.vc_slots & (args.vc_slots - 1):
        raise ArgumentError(f"--vc-slots {args.vc_slots}: must be a power of two")
    return TraceSettings(method=args.method, samples=args.samples,
                         structure=args.structure,
                         cells_per_triangle=args.cells_per_triangle, vc_slots=args.vc_slots,
                         vc_pool=args.vc_pool, mailbox=args.mailbox, maps=args.maps,
                         map_resolution=args.map_resolution)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m game",
                     description="Multi-map hard shadows and linear-light soft shadows.")
    sub = parser.add_subparsers(dest="command", parser_class=Parser)

    _add_play_parser(sub)
    cap = sub.add_parser("capture", help="render frames headless through EGL")
    cap.add_argument("scene", nargs="?", help="scene file (default: the built-in scene)")
    _add_method_option(cap)
    _add_frame_options(cap, dump_help="write npz + glb beside each frame")
    cap.add_argument("--overlay", action="store_true", help="draw the timing overlay")
    _add_camera_pass_options(cap)
    cap.add_argument("--soft", action="store_true",
                     help="light the frames by the linear light, with traced soft shadows "
                          "(voxel-cache, 32 samples; see python -m game trace)")
    _add_shadow_options(cap)

    _add_trace_parser(sub)
    add_bench_parser(sub)
    add_scenes_parser(sub)

    verify = sub.add_parser("verify", help="shadow error of dumped frames against Embree")
    verify.add_argument("dumps", type=path_value, metavar="DIR",
                        help="a capture or trace --dump folder")
    verify.add_argument("scene", nargs="?", help="the scene captured (default: the one the dumps "
                        "record); a different scene is refused")
    verify.add_argument("--out", type=path_value, metavar="FILE", help="write the errors as JSON")
    verify.add_argument("--images", action="store_true",
                        help="picture where the method and Embree disagree, beside each frame")
    return parser
