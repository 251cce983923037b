"""The results page's answer to the soft-shadow cache question, from a recorded cache run.

A cache run (``python -m game bench --suite cache --out docs/runs/NAME``) holds ``cache.csv``:
per scene, method and number of samples N, the CPU twin's simulated cache misses
(game/bench/cache_grind.py), its milliseconds, Embree's on the same rays, and whether its
visibility equals the GPU tracer's. Everything said here is computed from that file.
"""

from __future__ import annotations

import os
from pathlib import Path

from game.bench.rows import row_number
from game.bench.suite_records import SuiteRun, read_suite_run

CACHED = ("grid", "tri-cache", "voxel-cache")  # the methods compared; brute is the oracle
CACHE_COLUMNS = ("scene", "method", "samples", "d1_misses_per_ray", "ll_misses_per_ray",
                 "ms_per_ray_1thread", "embree_ms_per_ray", "gpu_differ", "points")


def is_cache_run(folder: Path) -> bool:
    return (folder / "cache.csv").is_file()


def load_cache_run(folder: Path) -> SuiteRun:
    """A cache run's folder; a missing or garbled file is refused in one line."""
    return read_suite_run(folder, "cache.csv", CACHE_COLUMNS, "cache run", "cache")


def _cell(rows: list[dict], scene: str, method: str, n: int) -> dict | None:
    return next((r for r in rows if r["scene"] == scene and r["method"] == method
                 and int(r["samples"]) == n), None)


def _fewer(rows: list[dict], key: str, scenes: list[str], samples: list[int]) -> tuple[int, int]:
    """In how many (scene, N) voxel-cache's ``key`` is below both grid's and tri-cache's."""
    wins = total = 0
    for scene in scenes:
        for n in samples:
            cells = [_cell(rows, scene, m, n) for m in CACHED]
            if any(c is None for c in cells):
                continue
            grid, tri, voxel = (row_number(c, key) for c in cells)
            total += 1
            wins += voxel < min(grid, tri)
    return wins, total


def _factors(rows: list[dict]) -> tuple[float, float]:
    """The least and the most a cached method's one-thread time per ray is Embree's."""
    factors = [row_number(r, "ms_per_ray_1thread") / row_number(r, "embree_ms_per_ray")
               for r in rows if r["method"] in CACHED
               and row_number(r, "embree_ms_per_ray") > 0]
    return min(factors), max(factors)


def cache_section(run: SuiteRun, here: Path) -> list[str]:
    """The section of the results page: the answer first, then a table per scene."""
    rows = run.rows
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    samples = sorted({int(r["samples"]) for r in rows})
    l1 = _fewer(rows, "d1_misses_per_ray", scenes, samples)
    ll = _fewer(rows, "ll_misses_per_ray", scenes, samples)
    fast = _fewer(rows, "ms_per_ray_1thread", scenes, samples)
    low, high = _factors(rows)
    differ = sum(int(row_number(r, "gpu_differ")) for r in rows)
    points = sum(int(row_number(r, "points")) for r in rows)
    rec = run.record
    where = Path(os.path.relpath(run.folder, here)).as_posix()
    lines = [
        "## Soft shadows: does the per-voxel cache spare the CPU's caches?", "",
        "The paper expects its per-voxel candidate arrays to make the L1 cache hits high. The "
        "GLSL tracer on llvmpipe cannot show that, so a CPU twin of the sampled methods "
        "(numba, `game/soft/cpu_twin.py`) traces the same points through the same structures, "
        "and valgrind's cache simulator counts its misses, cold, one thread "
        "(`game/bench/cache_grind.py`).", "",
        f"**What the figures say.** Of {l1[1]} (scene, N) pairs, `voxel-cache` has fewer L1 "
        f"misses per ray than both `grid` and `tri-cache` in {l1[0]}, fewer last-level misses "
        f"in {ll[0]}, and a shorter time per ray on one thread in {fast[0]}. On one thread "
        f"each cached method takes {low:.1f} to {high:.1f} times Embree's time per ray on the "
        f"same rays. The twin's visibility differs from the GPU tracer's on {differ} of "
        f"{points:,} points.", "",
        f"Run [`{run.name}`]({where}/run.json): `{rec['command']}`; the CPU twin under "
        f"{rec.get('cache_simulation', {}).get('tool', 'valgrind')}; {rec['date']}.", "",
        f"![misses and time per ray against N]({where}/cache.png)", ""]
    for scene in scenes:
        lines += [f"**{scene}**: grid / tri-cache / voxel-cache, misses per ray and per "
                  "shaded point, time per ray on one thread (µs; Embree's beside it)", ""]
        lines += ["| N | L1 misses per ray | last-level per ray | L1 per point | "
                  "last-level per point | µs per ray | Embree µs |",
                  "|---|---|---|---|---|---|---|"]
        for n in samples:
            cells = [_cell(rows, scene, m, n) for m in CACHED]
            if any(c is None for c in cells):
                continue
            def three(key: str, scale: float = 1.0, cells=cells) -> str:
                return " / ".join(f"{scale * row_number(c, key):.3g}" for c in cells)
            lines.append(f"| {n} | {three('d1_misses_per_ray')} | {three('ll_misses_per_ray')} "
                         f"| {three('d1_misses_per_point')} | {three('ll_misses_per_point')} "
                         f"| {three('ms_per_ray_1thread', 1e3)} | "
                         f"{1e3 * row_number(cells[0], 'embree_ms_per_ray'):.3g} |")
        lines.append("")
    return lines
