"""The results page's section on the window's frame rate, from a recorded window run
(``python -m game bench --suite window --out docs/runs/NAME``, game/bench/window_suite.py).

Every figure is computed here from ``window.csv``: frames per second by each run's CPU time, per
round, and the ratios the issues ask about, round by round.
"""

from __future__ import annotations

import os
import statistics
from pathlib import Path

from game.bench.rows import row_number
from game.bench.suite_records import SuiteRun, read_suite_run

COLUMNS = ("round", "method", "soft", "turn_degrees", "fps_cpu", "shade_ms", "frames")


def is_window_run(folder: Path) -> bool:
    return (folder / "window.csv").is_file()


def load_window_run(folder: Path) -> SuiteRun:
    """A window run's folder; a missing or garbled file is refused in one line."""
    return read_suite_run(folder, "window.csv", COLUMNS, "window run", "window")


def _key(row: dict) -> tuple[str, bool, bool]:
    return row["method"], row["soft"] == "True", row_number(row, "turn_degrees") != 0.0


def _label(key: tuple[str, bool, bool]) -> str:
    method, soft, turning = key
    return (f"{method}{', soft shadows' if soft else ''}, camera "
            f"{'turning a degree a frame' if turning else 'still'}")


def _fps(rows: list[dict], key: tuple) -> list[float]:
    """The key's frame rate in each round, in round order."""
    found = sorted((int(r["round"]), row_number(r, "fps_cpu")) for r in rows if _key(r) == key)
    return [fps for _, fps in found]


def _ratios(rows: list[dict], top: tuple, bottom: tuple) -> str:
    pairs = zip(_fps(rows, top), _fps(rows, bottom), strict=False)
    return " and ".join(f"{a / b:.2f}" for a, b in pairs) or "-"


def window_section(run: SuiteRun, here: Path) -> list[str]:
    """The section: how the run was made, a table of its runs, then the ratios."""
    rows, rec = run.rows, run.record
    where = Path(os.path.relpath(run.folder, here)).as_posix()
    code = f"; code `{rec['commit'][:10]}`" if rec.get("commit") else ""
    code += " with local changes" if rec.get("dirty") else ""
    frames = rows[0]["frames"]
    lines = ["## The window's frame rate", "",
             f"Run [`{run.name}`]({where}/run.json): `{rec['command']}`; {rec.get('renderer')}, "
             f"OpenGL {rec.get('version')}; timed by the CPU time of each run's process; "
             f"{rec['date']}{code}.", "",
             f"The walkaround as `play` opens it (overlay, FXAA and PCF on), the built-in scene "
             f"at 960x540 on GLFW's null platform, its walkers walking; {frames} timed frames a "
             "run, each run in its own process with llvmpipe rasterising in it "
             "(`LP_NUM_THREADS=0`), the runs taking turns in the opposite order in each round "
             "(game/bench/window_suite.py). A turning camera turns a degree a frame, back and "
             "forth within 30 degrees of its first view.", ""]
    keys = list(dict.fromkeys(_key(r) for r in rows))
    rounds = sorted({int(r["round"]) for r in rows})
    head = ["run"] + [f"fps, round {n}" for n in rounds] + ["shading pass ms (median)"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in keys:
        shade = statistics.median(row_number(r, "shade_ms") for r in rows if _key(r) == key)
        cells = [_label(key)] + [f"{fps:.2f}" for fps in _fps(rows, key)] + [f"{shade:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    soft = [k for k in keys if k[1]]
    method = soft[0][0] if soft else "clumped"
    lines += [f"- clumped's frame rate over single's, camera still: "
              f"{_ratios(rows, ('clumped', False, False), ('single', False, False))} "
              "(round by round).",
              f"- with soft shadows, {method}'s window keeps this share of its frame rate: "
              f"camera still {_ratios(rows, (method, True, False), (method, False, False))}, "
              f"turning {_ratios(rows, (method, True, True), (method, False, True))}.", ""]
    return lines
