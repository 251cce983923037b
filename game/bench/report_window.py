"""The results page's section on the window's frame rate, from a recorded window run
(``python -m game bench --suite window --out docs/runs/NAME``, game/bench/window_suite.py).

Every figure and every setting named is read from ``window.csv``: frames per second per round,
clumped's over single's, and the share of its frame rate the window keeps with soft shadows,
each paired round by round. On a CPU rasteriser the frame rates are by each run's CPU time (the
GL work runs in the process); on a GPU by wall time, which holds the GPU's work.
"""

from __future__ import annotations

import math
import statistics
from pathlib import Path

from game.bench.rows import row_number
from game.bench.suite_records import SuiteRun, read_suite_run
from game.errors import GameError
from game.gpu.context import software_renderer

COLUMNS = ("round", "method", "soft", "turn_degrees", "sweep_degrees", "pcf", "as_shown",
           "width", "height", "frames", "fps_cpu", "fps_wall", "shade_ms", "renderer")
FLAGS = ("soft", "pcf", "as_shown")


def is_window_run(folder: Path) -> bool:
    return (folder / "window.csv").is_file()


def load_window_run(folder: Path) -> SuiteRun:
    """A window run's folder; a missing or garbled file is refused in one line."""
    run = read_suite_run(folder, "window.csv", COLUMNS, "window run", "window")
    for k, row in enumerate(run.rows, start=2):
        bad = [c for c in FLAGS if row[c] not in ("True", "False")]
        bad += [c for c in ("round", "width", "height", "frames") if not row[c].isdigit()]
        bad += [c for c in ("fps_cpu", "fps_wall", "turn_degrees", "sweep_degrees", "shade_ms")
                if not math.isfinite(row_number(row, c))]
        bad += [c for c in ("fps_cpu", "fps_wall") if not row_number(row, c) > 0]
        if bad:
            raise GameError(f"{folder / 'window.csv'}: line {k}: no usable {', '.join(bad)}")
    return run


def _key(row: dict) -> tuple[str, bool, float]:
    return row["method"], row["soft"] == "True", row_number(row, "turn_degrees")


def _label(key: tuple[str, bool, float]) -> str:
    method, soft, turn = key
    camera = "still" if not turn else f"turning {turn:g} degree{'' if turn == 1 else 's'} a frame"
    return f"{method}{', soft shadows' if soft else ''}, camera {camera}"


def _fps(rows: list[dict], key: tuple, column: str) -> dict[int, float]:
    """The key's frame rate in each of its rounds."""
    return {int(r["round"]): row_number(r, column) for r in rows if _key(r) == key}


def _ratios(rows: list[dict], top: tuple, bottom: tuple, column: str) -> str:
    """``top``'s frame rate over ``bottom``'s in each round that holds both."""
    a, b = _fps(rows, top, column), _fps(rows, bottom, column)
    return " and ".join(f"{a[n] / b[n]:.2f}" for n in sorted(a) if n in b) or "-"


def _setup(rows: list[dict], column: str) -> str:
    first = rows[0]
    shown = ("as `play` opens it (overlay and FXAA on)" if first["as_shown"] == "True"
             else "without overlay or FXAA (the renderer's own picture)")
    sweep = max(row_number(r, "sweep_degrees") for r in rows)
    clock = ("each run's CPU time, with `LP_NUM_THREADS=0` so that llvmpipe rasterises in the "
             "process" if column == "fps_cpu" else "wall time")
    return (f"The walkaround {shown}, PCF {'on' if first['pcf'] == 'True' else 'off'}, the "
            f"built-in scene at {first['width']}x{first['height']} on GLFW's null platform, its "
            f"walkers walking; {first['frames']} timed frames a run, each run in its own "
            f"process, timed by {clock}; the runs take turns, in the opposite order in each "
            "round (game/bench/window_suite.py)."
            + (f" A turning camera turns back and forth within {sweep:g} degrees of its first "
               "view." if sweep else ""))


def window_section(run: SuiteRun, here: Path, header, table) -> list[str]:
    """The section: how the run was made, a table of its runs, then the ratios; ``header``
    and ``table`` are the results page's (game/bench/report.py)."""
    rows = run.rows
    column = "fps_cpu" if software_renderer(rows[0]["renderer"]) else "fps_wall"
    lines = ["## The window's frame rate", "", *header(run, here), _setup(rows, column), ""]
    keys = list(dict.fromkeys(_key(r) for r in rows))
    rounds = sorted({int(r["round"]) for r in rows})
    body = []
    for key in keys:
        fps = _fps(rows, key, column)
        shade = statistics.median(row_number(r, "shade_ms") for r in rows if _key(r) == key)
        body.append([_label(key)] + [f"{fps[n]:.2f}" if n in fps else "-" for n in rounds]
                    + [f"{shade:.1f}"])
    lines += table(["run"] + [f"fps, round {n}" for n in rounds] + ["shading pass ms (median)"],
                   body)
    soft = [k for k in keys if k[1]]
    method = soft[0][0] if soft else "clumped"
    turn = next((k[2] for k in keys if k[2]), 0.0)
    lines.append("- clumped's frame rate over single's, camera still: "
                 f"{_ratios(rows, ('clumped', False, 0.0), ('single', False, 0.0), column)} "
                 "(round by round).")
    if soft:
        lines.append(
            f"- with soft shadows, {method}'s window keeps this share of its frame rate: camera "
            f"still {_ratios(rows, (method, True, 0.0), (method, False, 0.0), column)}, turning "
            f"{_ratios(rows, (method, True, turn), (method, False, turn), column)}.")
    return lines + [""]
