"""The benchmark's sweep: its scenes, and the methods x parameters run on each.

A run is one scene with one method and one parameter set (:class:`RunSpec`); the sweep is the
list :func:`plan_runs` makes from the options.
"""

from __future__ import annotations

import hashlib
import math
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from game.bench import stability
from game.data import ASSET_DIR
from game.render.passes import PASSES_AND_TOTAL
from game.scene import default_scene_path, reference_scene_path
from game.shadows import clumping, registry
from game.shadows.plan import ShadowSettings

FPS = 30.0                  # scene seconds per timing frame: 1 / FPS
ORBIT_DEG = 1.0             # camera yaw per timing frame about the scene camera's target
FLICKER_DEG = 0.25          # camera yaw per flicker frame (time frozen)
ERROR_SPACING_S = 0.75      # scene seconds between error frames (characters move between them)
PASSES = PASSES_AND_TOTAL   # timed per run: a column each of median, p95 and least
PARAM_KEYS = ("clumping", "clump_count", "texels_per_metre", "clump_resolution",
              "character_resolution", "character_texels_per_pixel", "view_resolution",
              "max_clump_resolution", "single_resolution", "cascades", "cascade_lambda",
              "cascade_resolution")
# Walker counts of the 4 x 4 town's crowd series (16 is town_4x4 itself).
CROWD_SERIES = (4, 64, 128, 256)
# Lights of the night town's series: the moon and street lamps, 1 to 64 lights in all; and the
# walkers of its 16-light town (12 is lights_16 itself).
LIGHT_SERIES = (1, 4, 16, 64)
LIGHT_CHARACTER_SERIES = (4, 48)
# Bench-only parameter: re-render every cached map every frame, to measure the cost of many
# small maps (framebuffer and layer switches, clears) against one map at equal triangles.
RERENDER = "rerender_static"
# (clump count, clump map resolution) of that experiment: the same statics and the same texels
# (4096^2) in 1 to 64 maps, so what grows with the count is the per-map cost.
SWITCH_SERIES = ((1, 4096), (4, 2048), (16, 1024), (64, 512))
COLUMNS = (
    ["run", "scene", "scene_sha256", "group", "factor", "value", "method", *PARAM_KEYS, RERENDER,
     "width",
     "height",
     "frames", "warmup", "renderer", "version", "clock", "static_triangles", "characters"]
    + [f"{p}_ms_{stat}" for p in PASSES for stat in ("median", "p95", "min")]
    + ["repeats", "total_ms_spread"]
    + ["maps_total", "maps_rendered", "triangles_to_maps", "texels_to_maps",
       "camera_triangles", "shadow_memory_mib", "maps_per_fragment",
       "map_candidates_per_fragment", "depth_first", "static_maps",
       "footprint_overlap", "static_texels_per_metre", "lights", "error", "error_worst_light",
       "misclassified", "shadowed",
       "error_frames", "flicker", "flicker_raw", "flicker_reference", "nan_pixels", "notes",
       "status", "seconds"]
)


# The scene groups whose methods are compared head to head (acceptance, Pareto charts): the
# built-in main scene, the towns, the real assets, and the user's own scene files.
COMPARED_GROUPS = ("main", "town", "real", "lights", "user")

# The real third-party corpus (assets/REAL_ASSETS.md), benched where assets/fetch_real.py has
# fetched it: a level as one file and as separate files, and props under a spot and a point light.
REAL_DIR = ASSET_DIR / "real"
REAL_SCENES = ("monastery", "monastery_parts", "props_spot", "props_point")


@dataclass(frozen=True)
class BenchScene:
    """One scene of the sweep."""

    key: str
    group: str               # main | town | real | lights | stability | user
    text: str                # the scene file's text (written to OUT/scenes/KEY.toml)
    factor: str = ""         # stability factor, or the scaling axis of a town
    value: float = 0.0
    accuracy_expected: bool = True
    path: Path | None = None  # a scene file loaded where it lies (its meshes beside it)

    @property
    def sha256(self) -> str:
        """Of the scene's text: rows of another text under the same key are measured again."""
        return hashlib.sha256(self.text.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class RunSpec:
    scene: str
    method: str
    params: tuple[tuple[str, object], ...] = ()

    def settings(self) -> ShadowSettings:
        params = {k: v for k, v in self.params if k != RERENDER}
        return ShadowSettings(method=self.method, **params)

    @property
    def rerender(self) -> bool:
        return bool(dict(self.params).get(RERENDER, False))

    def run_id(self, size: tuple[int, int]) -> str:
        p = ",".join(f"{k}={v}" for k, v in self.params) or "defaults"
        return f"{self.scene}|{self.method}|{p}|{size[0]}x{size[1]}"


@dataclass
class BenchOptions:
    out: Path
    quick: bool = False
    size: tuple[int, int] = (320, 180)
    frames: int = 8
    warmup: int = 2
    error_frames: int = 2
    flicker_frames: int = 3
    repeat: int = 1                      # timings per run, interleaved within a scene
    scenes: list[str] | None = None      # only these scene keys (fnmatch patterns)
    user_scenes: list[BenchScene] = field(default_factory=list)  # scene files: user_scene()
    methods: list[str] | None = None
    # --param: each value of each parameter, as its own run of every method that reads it
    params: dict[str, tuple] = field(default_factory=dict)
    reference: bool = True
    progress: bool = True
    deadline: float | None = None        # time.monotonic() after which no new run starts
    clock: str = "auto"                  # game/gpu/timing.py CLOCKS
    log: Callable[[str], None] = field(default=lambda line: print(line, file=sys.stderr))


def town_text(blocks: int, characters: int, name: str) -> str:
    """A town like assets/town_1m.toml with ``blocks`` per side; the camera keeps its framing."""
    span = blocks * 50.0 + 10.0
    k = span / 410.0
    return f"""name = "{name}"

[camera]
position = [0.0, {190.0 * k:.4g}, {330.0 * k:.4g}]
target   = [0.0, 0.0, {20.0 * k:.4g}]
fov      = 55.0
near     = {max(0.1, 1.0 * k):.4g}
far      = {1000.0 * k:.4g}

[light]
kind      = "directional"
direction = [-0.4, -1.0, -0.3]
color     = [1.0, 0.97, 0.92]

[generate]
seed                = 1
blocks              = {blocks}
block_size          = 40.0
street_width        = 10.0
buildings_per_block = 4
trees_per_block     = 8
max_storeys         = 8
detail              = 2
characters          = {characters}
"""


def night_text(lights: int, name: str, characters: int | None = None) -> str:
    """assets/night_town.toml with ``lights`` lights in all (the moon and ``lights - 1``
    lamps), and ``characters`` walkers (default: its own)."""
    text = (ASSET_DIR / "night_town.toml").read_text(encoding="utf-8")
    keys = {"lamps": lights - 1}
    if characters is not None:
        keys["characters"] = characters
    for key, value in keys.items():
        start = text.find(f"\n{key} ")
        end = text.find("\n", start + 1)
        if start < 0:
            raise ValueError(f"assets/night_town.toml no longer sets {key}")
        text = text[:start] + f"\n{key:<19} = {value}" + text[end:]
    return text.replace('name = "night_town"', f'name = "{name}"')


def bench_scenes(quick: bool) -> list[BenchScene]:
    """The courtyard (the reference scene) and the built-in town square, towns at three sizes
    (and three walker counts), the night town with 1 to 64 lights, the real corpus where it is
    fetched, stability scenes."""
    out = [BenchScene(key, "main", path.read_text(encoding="utf-8"), path=path)
           for key, path in (("courtyard", reference_scene_path()),
                             ("default", default_scene_path()))]
    if quick:
        out.append(BenchScene("town_2x2", "town", town_text(2, 16, "town_2x2"), "size", 2))
    else:
        # Town sizes with 16 walkers (the 8 x 8 one is assets/town_1m.toml: 1.06 M triangles),
        # the 4 x 4 town with 4 to 256 walkers, the 1 M town with 64, and a crowd.
        for blocks in (2, 4, 8):
            out.append(BenchScene(f"town_{blocks}x{blocks}", "town",
                                  town_text(blocks, 16, f"town_{blocks}x{blocks}"), "size",
                                  blocks))
        for n in CROWD_SERIES:
            out.append(BenchScene(f"town_4x4_c{n}", "town", town_text(4, n, f"town_4x4_c{n}"),
                                  "characters", n))
        out.append(BenchScene("town_8x8_c64", "town", town_text(8, 64, "town_8x8_c64"),
                              "characters", 64))
        # A crowd on one block: 128 walkers in the streets around four buildings.
        out.append(BenchScene("crowd_128", "town", town_text(1, 128, "crowd_128")))
        # The night town with 1 to 64 lights: the moon, then street lamps.
        for n in LIGHT_SERIES:
            out.append(BenchScene(f"lights_{n}", "lights", night_text(n, f"lights_{n}"),
                                  "lights", n))
        for n in LIGHT_CHARACTER_SERIES:
            out.append(BenchScene(f"lights_16_c{n}", "lights",
                                  night_text(16, f"lights_16_c{n}", n), "characters", n))
    for name in REAL_SCENES if not quick else ():
        path = REAL_DIR / f"{name}.toml"
        if path.is_file():
            out.append(BenchScene(name, "real", path.read_text(encoding="utf-8"), path=path))
    for case in stability.cases(quick):
        out.append(BenchScene(f"stab_{case.name}", "stability", case.text, case.factor,
                              case.value, case.accuracy_expected))
    return out


def user_scene(path: Path, taken: Iterable[str]) -> BenchScene:
    """A user's scene file as a bench scene, keyed by its folder name (unique among ``taken``)."""
    from game.scene import load_scene

    scene = load_scene(path)  # a bad file fails here, in one line, before any run
    key = base = scene.folder_name
    taken = set(taken)
    n = 1
    while key in taken:
        n += 1
        key = f"{base}_{n}"
    return BenchScene(key, "user", path.read_text(encoding="utf-8"), path=path)


def parse_param(text: str) -> tuple[str, tuple]:
    """``KEY=V1,V2,...`` of :data:`PARAM_KEYS`, each value of the setting's own type."""
    key, sep, values = text.partition("=")
    key = key.strip().replace("-", "_")
    if not sep or not values.strip():
        raise ValueError(f"{text!r}: write KEY=VALUE[,VALUE...], for example "
                         "clump_resolution=512,2048")
    if key not in PARAM_KEYS:
        raise ValueError(f"{key!r}: not a swept parameter; valid: {', '.join(PARAM_KEYS)}")
    kind = {"clumping": str, "clump_count": int, "texels_per_metre": float,
            "cascade_lambda": float, "character_texels_per_pixel": float,
            "view_resolution": bool}.get(key, int)
    out = []
    for v in (v.strip() for v in values.split(",")):
        if kind is bool:
            if v.lower() not in ("on", "off"):
                raise ValueError(f"{key}: {v!r} is not on or off")
            if (v.lower() == "on") not in out:
                out.append(v.lower() == "on")
            continue
        try:
            value = kind(v)
        except ValueError:
            what = "a whole number" if kind is int else "a number"
            raise ValueError(f"{key}: {v!r} is not {what}") from None
        if kind is str and value not in clumping.STRATEGIES:
            raise ValueError(f"{key}: {v!r} is not one of {', '.join(clumping.STRATEGIES)}")
        zero_ok = key == "character_texels_per_pixel"  # 0: every map at the most
        if kind is not str and not (math.isfinite(value) and (value > 0 or zero_ok and value == 0)):
            raise ValueError(f"{key}: must be {'0 or more' if zero_ok else 'positive'}, got {v!r}")
        if key == "cascade_lambda" and value > 1:
            raise ValueError(f"{key}: must be 0..1, got {v!r}")
        if value not in out:
            out.append(value)
    return key, tuple(out)


def param_grid(key: str, methods: Iterable[str], params: dict[str, tuple]) -> list[RunSpec]:
    """Every method at its defaults, then one run per value of each ``--param`` of the methods
    that read that parameter."""
    specs = [RunSpec(key, m) for m in methods]
    for name, values in params.items():
        for m in methods:
            if name in registry.METHODS[m].parameters:
                specs += [RunSpec(key, m, _p(**{name: v})) for v in values]
    return list(dict.fromkeys(specs))  # one run per run id, in order


def _p(**kw) -> tuple[tuple[str, object], ...]:
    return tuple(sorted(kw.items()))


def method_grid(scene: BenchScene, quick: bool, max_texture: int) -> list[RunSpec]:
    """Methods x parameters for one scene; the full grid on the courtyard and the 1 M town."""
    k = scene.key
    defaults = [RunSpec(k, method) for method in registry.MAP_METHODS]
    if scene.group == "stability":
        if scene.factor == "maps":  # hundreds of character maps: keep their memory small
            small = _p(clump_resolution=256, character_resolution=256)
            return [RunSpec(k, "clumped", small), *(s for s in defaults if s.method != "clumped")]
        return defaults
    if quick:
        specs = [*defaults, RunSpec(k, "clumped", _p(clumping="world")),
                 RunSpec(k, "single", _p(single_resolution=1024)),
                 RunSpec(k, "csm", _p(cascade_resolution=1024))]
        if scene.group == "town":
            specs += [RunSpec(k, "clumped", _p(clump_count=n, clump_resolution=r,
                                               **{RERENDER: True})) for n, r in SWITCH_SERIES]
        return specs
    if scene.group == "real":  # the level against single at the sizes an engine would use
        return [*defaults, RunSpec(k, "clumped", _p(clumping="world"))] + [
            RunSpec(k, "single", _p(single_resolution=r)) for r in (8192,) if r <= max_texture]
    if k == "town_4x4":
        return [*defaults, RunSpec(k, "clumped", _p(clumping="world"))] + [
            RunSpec(k, "clumped", _p(clump_count=n, clump_resolution=r, **{RERENDER: True}))
            for n, r in SWITCH_SERIES]
    if scene.factor == "characters" or k == "crowd_128":
        # Every character map at the most, every frame, none skipped or grouped: what sizing
        # the maps by need saves, measured beside it.
        return [*defaults, RunSpec(k, "clumped", _p(character_texels_per_pixel=0.0))]
    if k not in ("courtyard", "town_8x8"):
        return [*defaults, RunSpec(k, "clumped", _p(clumping="world"))]
    specs = list(defaults)
    for space in clumping.STRATEGIES:
        for count in (4, 16, 64):
            specs.append(RunSpec(k, "clumped", _p(clumping=space, clump_count=count)))
    specs.append(RunSpec(k, "clumped", _p(clumping="world")))
    for res in (256, 1024):
        specs.append(RunSpec(k, "clumped", _p(character_resolution=res)))
    # 1024² maps at 64 texels per metre: what the defaults' larger maps and denser target buy.
    specs.append(RunSpec(k, "clumped", _p(clump_resolution=1024, texels_per_metre=64.0)))
    for res in (512, 1024, 2048, 8192, 16384):
        if res <= max_texture:
            specs.append(RunSpec(k, "single", _p(single_resolution=res)))
    for res in (2048, 8192):
        specs.append(RunSpec(k, "static-dynamic", _p(single_resolution=res)))
    for res in (1024, 4096):
        specs.append(RunSpec(k, "csm", _p(cascade_resolution=res)))
    for lam in (0.5, 0.95):
        specs.append(RunSpec(k, "csm", _p(cascade_lambda=lam)))
    return specs


def selected(key: str, patterns: Iterable[str] | None) -> bool:
    from fnmatch import fnmatch

    return patterns is None or any(fnmatch(key, p) for p in patterns)


def plan_runs(opts: BenchOptions, max_texture: int) -> list[tuple[BenchScene, RunSpec]]:
    """The runs of the sweep: the built-in scenes the patterns select (all without patterns or
    scene files), then the user's scene files. A scene file, or ``--param``, gets every method
    at its defaults plus the ``--param`` values instead of the built-in grid."""
    if opts.user_scenes and not opts.scenes:
        scenes = []  # only the user's files
    else:
        scenes = [b for b in bench_scenes(opts.quick) if selected(b.key, opts.scenes)]
    methods = [m for m in registry.MAP_METHODS if opts.methods is None or m in opts.methods]
    runs = []
    for bscene in scenes + opts.user_scenes:
        if bscene.group == "user" or opts.params:
            specs = param_grid(bscene.key, methods, opts.params)
        else:
            specs = [s for s in method_grid(bscene, opts.quick, max_texture)
                     if s.method in methods]
        runs += [(bscene, spec) for spec in specs]
    return runs


