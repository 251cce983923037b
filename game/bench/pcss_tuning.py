"""pcss's tuning: every combination of its taps, their spacing, the in-triangle test, jitter and
the map's resolution, scored by RMSE against the analytic visibility on the tuning scenes, with
the frame's milliseconds beside it.

``python -m game.bench.pcss_tuning --scenes assets/courtyard.toml,assets/default.toml --out DIR``
writes ``DIR/pcss_tuning.csv``, one row per combination and scene, and prints the combinations
in order of their mean error. The defaults of :class:`~game.soft.raster.PcssTuning` were picked
from this table (docs/design/raster-soft.md); a scene left out of the tuning checks them.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import sys
from pathlib import Path

import numpy as np

from game.bench.rows import write_table
from game.gpu import context
from game.render.renderer import Renderer, View
from game.scene import load_scene
from game.soft.methods import MAP_RESOLUTION, TraceSettings
from game.soft.raster import PcssTuning

GRID = {"blocker_taps": (16, 32, 64), "filter_taps": (8, 16, 32), "search_power": (2.0, 3.0, 4.0),
        "in_triangle": (True, False), "jitter": (True, False)}
RESOLUTIONS = (MAP_RESOLUTION, 2 * MAP_RESOLUTION)
REPEATS = 3
FIELDS = ("scene", *GRID, "map_resolution", "rmse_analytic", "frame_ms")


def tune(ctx, path: Path, size: tuple[int, int], log=print) -> list[dict]:
    """Every combination on one scene; rows of FIELDS."""
    scene = load_scene(path)
    renderer = Renderer(ctx, scene, size, gbuffer=True)
    rows = []
    try:
        renderer.render(0.0, View.from_camera(scene.camera, size))
        exact = renderer.trace(0.0, TraceSettings(method="analytic")).visibility
        covered = np.isfinite(exact)
        renderer.trace(0.0, TraceSettings(method="pcss"))  # makes the raster methods' pass
        raster = renderer.traced.raster
        for values in itertools.product(*GRID.values()):
            tuning = PcssTuning(**dict(zip(GRID, values, strict=True)))
            for resolution in RESOLUTIONS:
                settings = TraceSettings(method="pcss", map_resolution=resolution)
                raster.pcss = tuning
                runs = [renderer.trace(0.0, settings) for _ in range(REPEATS)]
                err = runs[-1].visibility[covered] - exact[covered]
                ms = np.median([r.ms["total"] - r.ms["build_static"] for r in runs])
                rows.append({"scene": path.stem, **dataclasses.asdict(tuning),
                             "map_resolution": resolution,
                             "rmse_analytic": round(float(np.sqrt(np.mean(err ** 2))), 6),
                             "frame_ms": round(float(ms), 3)})
                log(f"{path.stem}: {rows[-1]}")
    finally:
        renderer.release()
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m game.bench.pcss_tuning", description=__doc__)
    parser.add_argument("--scenes", default="assets/courtyard.toml,assets/default.toml")
    parser.add_argument("--size", default="160x90")
    parser.add_argument("--out", type=Path, default=Path("bench"))
    args = parser.parse_args(argv)
    size = tuple(int(x) for x in args.size.lower().split("x"))
    ctx = context.create_headless()
    try:
        rows = [row for p in args.scenes.split(",") for row in tune(ctx, Path(p), size)]
    finally:
        ctx.release()
    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / "pcss_tuning.csv", rows, FIELDS)
    keys = [*GRID, "map_resolution"]
    combos: dict[tuple, list[dict]] = {}
    for row in rows:
        combos.setdefault(tuple(row[k] for k in keys), []).append(row)
    ranked = sorted(combos.items(), key=lambda kv: np.mean([r["rmse_analytic"] for r in kv[1]]))
    for combo, mine in ranked[:10]:
        print(dict(zip(keys, combo, strict=True)),
              f"mean rmse {np.mean([r['rmse_analytic'] for r in mine]):.5f}, mean ms "
              f"{np.mean([r['frame_ms'] for r in mine]):.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
