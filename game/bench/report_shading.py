"""The results page's shading-pass part of the paper's second question: what clumped's camera
pass costs beside one map's, per scene and frame size, computed from the recorded runs.

A pair is clumped and ``single`` at their defaults on the same scene and frame size in the same
run. The bench alternates its methods within each repeat, so a pair's figures come from
interleaved frames.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path

from game.bench.acceptance import is_default
from game.bench.rows import camera_ms, maps_ms, row_number

CAMERA_TARGET = 1.15   # clumped's camera pass over single's, at most
FRAME_TARGET = 0.9     # clumped's frame over single's, at most


def shading_pairs(rows: list[dict]) -> list[tuple[dict, dict]]:
    """(clumped, single) rows at defaults on the same scene and size, in CSV order."""
    singles = {(r["scene"], r["width"], r["height"]): r for r in rows
               if r["method"] == "single" and is_default(r)}
    return [(r, singles[(r["scene"], r["width"], r["height"])]) for r in rows
            if r["method"] == "clumped" and is_default(r)
            and (r["scene"], r["width"], r["height"]) in singles]


def _ratio(a: float, b: float) -> float:
    return a / b if b > 0 and math.isfinite(a) and math.isfinite(b) else math.nan


def shading_section(runs, here: Path, header: Callable[[object, Path], list[str]]
                    ) -> list[str]:
    """The camera pass against one map's, per run that has pairs; ``header`` writes a run's
    command and renderer."""
    found = [(run, shading_pairs(run.rows)) for run in runs]
    every = [p for _, pairs in found for p in pairs]
    lines = ["### The shading pass: finding and reading many maps", ""]
    if not every:
        return lines + ["No recorded run has clumped and `single` at their defaults on one "
                        "scene.", ""]
    camera = [_ratio(camera_ms(c), camera_ms(s)) for c, s in every]
    frames = [_frame_ratio(c, s) for c, s in every]
    lines += [f"**What the figures say.** Of {len(every)} pairs, clumped's camera pass (cull + "
              f"shade) is within {CAMERA_TARGET:g}x of `single`'s in "
              f"{sum(r <= CAMERA_TARGET for r in camera)}, and its frame at most "
              f"{FRAME_TARGET:g}x of `single`'s in {sum(r <= FRAME_TARGET for r in frames)}. "
              f"Camera-pass ratios range from {min(camera):.2f}x to {max(camera):.2f}x.", ""]
    head = ["scene", "size", "camera ms, clumped / single", "camera ratio", "map passes ms",
            "frame ratio", "maps read per pixel", "map records per pixel",
            "frames depth first"]
    for run, pairs in found:
        if not pairs:
            continue
        body = [[c["scene"], f"{c['width']}x{c['height']}",
                 f"{camera_ms(c):.1f} / {camera_ms(s):.1f}",
                 f"{_ratio(camera_ms(c), camera_ms(s)):.2f}x",
                 f"{maps_ms(c):.1f} / {maps_ms(s):.1f}",
                 f"{_frame_ratio(c, s):.2f}x",
                 f"{_share(c, 'maps_per_fragment')} / {_share(s, 'maps_per_fragment')}",
                 f"{_share(c, 'map_candidates_per_fragment')} / "
                 f"{_share(s, 'map_candidates_per_fragment')}",
                 f"{_share(c, 'depth_first')} / {_share(s, 'depth_first')}"] for c, s in pairs]
        lines += header(run, here) + ["| " + " | ".join(head) + " |",
                                      "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(row) + " |" for row in body] + [""]
        chart = run.folder / "charts" / "camera_maps.png"
        if chart.is_file():
            where = Path(os.path.relpath(chart, here)).as_posix()
            lines += [f"![camera pass against maps, run {run.name}]({where})", ""]
        lines += per_light_lines(run, pairs, here)
    lines += density_section(runs, here, header)
    lines += ["What the camera pass still pays above one map's, the search through the grid "
              "and the finer texels: [the architecture]"
              "(design/architecture.md#many-small-maps-or-one-large-one); how the cached maps' "
              "[depth bounds](design/depth-bounds.md) settle most reads.", ""]
    return lines


def per_light_lines(run, pairs: list[tuple[dict, dict]], here: Path) -> list[str]:
    """What each added light costs the camera pass on the night town (the bench's lights
    series), clumped beside ``single``, where the run has two light counts or more."""
    # The runs' rows are the finished ones already (game/bench/report.py); a row may still lack
    # a figure.
    def measured(row: dict) -> bool:
        return math.isfinite(camera_ms(row)) and math.isfinite(row_number(row, "lights"))

    series = sorted(((row_number(c, "lights"), c, s) for c, s in pairs
                     if c["group"] == "lights" and c["factor"] == "lights"
                     and measured(c) and measured(s)),
                    key=lambda t: t[0])
    counts = [n for n, _, _ in series]
    # One pair a light count: two of one count (two frame sizes, say) have no one step.
    if len(counts) < 2 or len(set(counts)) < len(counts):
        return []
    (few, c0, s0), (many, c1, s1) = series[0], series[-1]
    added = many - few

    def step(first: dict, last: dict) -> str:
        return (f"{camera_ms(first):.1f} to {camera_ms(last):.1f} ms, "
                f"{(camera_ms(last) - camera_ms(first)) / added:+.1f} ms a light")

    lines = [f"**Each added light** (the night town with {', '.join(f'{n:.0f}' for n in counts)}"
             f" lights, run {run.name}): "
             f"from {few:.0f} to {many:.0f} lights clumped's camera pass goes from "
             f"{step(c0, c1)}; `single`'s from {step(s0, s1)}.", ""]
    chart = run.folder / "charts" / "lights.png"
    if chart.is_file():
        where = Path(os.path.relpath(chart, here)).as_posix()
        lines += [f"![cost against lights, run {run.name}]({where})", ""]
    return lines


def _frame_ratio(clumped: dict, single: dict) -> float:
    return _ratio(row_number(clumped, "total_ms_median"), row_number(single, "total_ms_median"))


def _share(row: dict, column: str) -> str:
    value = row_number(row, column)
    return f"{value:.2f}" if math.isfinite(value) else "n/a"


def density_rows(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """Per (scene, size) where ``single`` ran at more than one side: clumped at its defaults,
    then ``single`` at each side recorded, smallest first."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        params = r["run"].split("|")[2]
        wanted = (r["method"] == "clumped" and params == "defaults") or (
            r["method"] == "single" and (params == "defaults"
                                         or params.startswith("single_resolution=")))
        if wanted:
            groups.setdefault((r["scene"], f"{r['width']}x{r['height']}"), []).append(r)
    out = {}
    for key, group in groups.items():
        singles = sorted((r for r in group if r["method"] == "single"),
                         key=lambda r: row_number(r, "single_resolution"))
        clumped = [r for r in group if r["method"] == "clumped"]
        if clumped and len(singles) > 1:
            out[key] = clumped[:1] + singles
    return out


def density_section(runs, here: Path, header: Callable[[object, Path], list[str]]
                    ) -> list[str]:
    """The camera pass beside the shadow error, for runs that vary one map's side: a finer map
    costs the shading pass more, at every side."""
    found = [(run, density_rows(run.rows)) for run in runs]
    if not any(groups for _, groups in found):
        return []
    lines = ["**The camera pass at equal accuracy.** Finer shadow texels cost the shading pass "
             "too: each pixel reads texels its neighbours do not share, so fewer reads hit the "
             "texture cache. The runs below give one map at several sides beside clumped, so "
             "the camera pass can be compared where the errors are alike.", ""]
    head = ["scene", "size", "method", "camera ms", "frame ms", "error"]
    for run, groups in found:
        if not groups:
            continue
        body = []
        for (scene, size), group in groups.items():
            for r in group:
                name = (r["method"] if r["method"] == "clumped"
                        else f"single {int(row_number(r, 'single_resolution'))}^2")
                error = row_number(r, "error")
                body.append([scene, size, name, f"{camera_ms(r):.1f}",
                             f"{row_number(r, 'total_ms_median'):.1f}",
                             f"{100 * error:.2f}%" if math.isfinite(error) else "n/a"])
        lines += header(run, here) + ["| " + " | ".join(head) + " |",
                                      "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(row) + " |" for row in body] + [""]
    return lines
