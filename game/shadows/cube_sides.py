"""The cube of maps around a point light: the baselines' side for a lamp, a clumped cube's side
within its light's share, and the note where it stays much coarser than the baselines' cube.

A point light's clumps that surround it share one cube of maps around the light, the kind of map
the baselines draw for every point light. Its receivers are the light's nearest, whose shadows
are the largest on screen.
"""

from __future__ import annotations

from collections.abc import Callable

from game.scene.model import Light
from game.shadows.budget import BASELINE_BUDGET_SHARE, MIN_MAP_RESOLUTION
from game.shadows.light_kinds import kind_of
from game.shadows.method import ShadowMethod, SharesBudget
from game.shadows.plan import ShadowSettings, budget_of, layer_bytes

# A clumped point light's cube with faces this many times coarser than the baselines' cube
# gets a note. At half the baselines' side the clumps beside the light, in frusta finer than
# either cube, still keep clumped ahead of them (random scene 20's range-less lamp, the night
# town's lamps); at a quarter the cube's texels decide the error where it holds the receivers
# (random scene 59 with faces of 1024^2: every pixel its point light misclassified lay in its
# cube alone).
COARSE_CUBE_RATIO = 4


def lamp_side(light: Light, settings: ShadowSettings, scene_radius: float) -> int:
    """The side of a baseline's maps (or cube faces) for a light with a range: texels as
    fine at the edge of its range as ``single_resolution`` gives across the scene, from
    ``lamp_resolution`` doubled up to ``single_resolution``. A lamp that lights a street corner
    keeps ``lamp_resolution``; one whose range spans the scene lights as much as a sun does,
    and at ``lamp_resolution`` its far shadows would be four times coarser than the sun's."""
    reach = light.range / max(scene_radius, 1e-6)
    side = min(settings.lamp_resolution, settings.single_resolution)
    while side < settings.single_resolution * min(reach, 1.0):
        side *= 2
    return min(side, settings.single_resolution)


def finer_cubes(methods: list[ShadowMethod], shares: list[float], sides: list[int],
                create: Callable[[int, float], ShadowMethod], settings: ShadowSettings,
                scene_radius: float) -> None:
    """Plan light k again at twice its side (``sides[k]``, read by ``create(k, share)``) while
    its clumps take a cube around the light, still meet the density target and fit its share,
    up to the side the baselines give its cube. Its share held the cube at a fraction of the
    baselines' texels and went unused, or to other lights, where it could make the receivers
    that only the cube holds, the light's nearest, as sharp as the baselines make them."""
    for k, method in enumerate(methods):
        base = min(baseline_side(method.light, settings, scene_radius),
                   settings.max_clump_resolution)
        while (isinstance(method, SharesBudget) and method.cube_side is not None
               and method.meets_density and sides[k] * 2 <= base):
            sides[k] *= 2
            finer = create(k, shares[k])
            # The planner may halve the side again itself (more clumps at the target): then
            # the cube got no finer, and a larger side would not make it so.
            if not (isinstance(finer, SharesBudget) and finer.meets_density
                    and (finer.cube_side or 0) > method.cube_side):
                sides[k] //= 2
                break
            methods[k] = method = finer


def baseline_side(light: Light, settings: ShadowSettings, scene_radius: float) -> int:
    """The side of the baselines' maps (or cube faces) for ``light``."""
    return (settings.single_resolution if light.range is None
            else lamp_side(light, settings, scene_radius))


def baselines_memory(lights: list[Light], settings: ShadowSettings, scene_radius: float,
                     walkers: bool) -> list[float]:
    """What each light is owed by default, in MiB: the baselines' maps of it (one map, or a
    cube's six faces, at :func:`baseline_side`, every side halved as often as the baselines'
    own budget halves them), and a layer of that side for its walkers' maps where there are
    walkers. With that much, a light whose clumps are coarser than the baselines' maps can take
    those maps for its statics, and is never held coarser than them for want of memory."""
    sides = [baseline_side(light, settings, scene_radius) for light in lights]
    layers = [kind_of(light).max_maps_per_caster for light in lights]
    cap = BASELINE_BUDGET_SHARE * budget_of(settings) * 2**20
    while (sum(n * layer_bytes(side) for n, side in zip(layers, sides, strict=True)) > cap
           and max(sides) > MIN_MAP_RESOLUTION):
        sides = [max(1, side // 2) for side in sides]
    return [(n + walkers) * layer_bytes(side) / 2**20
            for n, side in zip(layers, sides, strict=True)]


def coarse_cube_notes(methods: list[ShadowMethod], settings: ShadowSettings,
                      scene_radius: float) -> list[str]:
    """One note per pair of sides: the clumped point lights whose cube around the light has
    faces :data:`COARSE_CUBE_RATIO` or more times coarser than the cube the baselines give the
    same light. The baselines spend their own budget (``BASELINE_BUDGET_SHARE`` times
    clumped's) on one cube per point light; a share of clumped's budget holds fewer texels,
    and the receivers that only the cube holds get wider texels than the baselines give."""
    coarse: dict[tuple[int, int], list[int]] = {}
    for k, method in enumerate(methods):
        side = method.cube_side if isinstance(method, SharesBudget) else None
        if side is None:  # only a point light's clumps take a cube
            continue
        base = baseline_side(method.light, settings, scene_radius)
        if side * COARSE_CUBE_RATIO <= base:
            coarse.setdefault((side, base), []).append(k)
    shared = f" ({len(methods)} lights share it)" if len(methods) > 1 else ""
    return [f"{'light' if len(ks) == 1 else 'lights'} {', '.join(map(str, ks))}: the clumps "
            f"around the light share a cube of {side}^2 faces where single and static-dynamic "
            f"draw a cube of {base}^2 with these settings, texels {base // side} times as wide: "
            f"the {budget_of(settings):g} MiB budget{shared} goes to clump maps of {side}^2 "
            f"(the baselines' budget is {BASELINE_BUDGET_SHARE * budget_of(settings):g} MiB)"
            for (side, base), ks in coarse.items()]
