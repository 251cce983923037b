"""The results page, generated from recorded runs: ``python -m game bench --report [ROOT]``.

A recorded run is a bench output folder under ``ROOT/docs/runs/``: the bench's own ``bench.csv``
and the ``run.json`` it writes beside it (command, renderer, date, code). This module reads every
such folder and writes ``ROOT/docs/results.md`` whole, and the small headline table between the
figure markers of ``ROOT/README.md``. Every figure on both is a median, spread or ratio computed
here from the CSV, so a figure cannot drift from its run, and its copies cannot drift from each
other; running the report twice writes the same bytes.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

from game.app import outputs
from game.bench.acceptance import is_default
from game.bench.report_accuracy import (
    accuracy_section,
    is_accuracy_run,
    load_accuracy_run,
)
from game.bench.report_cache import cache_section, is_cache_run, load_cache_run
from game.bench.report_shading import shading_section
from game.bench.report_window import is_window_run, load_window_run, window_section
from game.bench.rows import camera_ms, maps_ms, read_rows, row_number
from game.bench.runs import COMPARED_GROUPS, PARAM_KEYS, RERENDER
from game.bench.suite_records import SuiteRun
from game.errors import GameError
from game.gpu.timing import THREAD_CLOCK

BEGIN = "<!-- figures:begin -->"
END = "<!-- figures:end -->"
RECORD_KEYS = ("command", "renderer", "version", "date")
# The charts a run section shows, at most, from the bench's ``charts/`` folder.
CHARTS_PER_RUN = 2
NO_FIGURE = "-"


@dataclass(frozen=True)
class RecordedRun:
    """One folder of ``docs/runs``: its record (``run.json``) and its finished rows."""

    name: str
    folder: Path
    record: dict
    rows: list[dict]


def write_report(root: Path) -> list[Path]:
    """Write ``docs/results.md`` and the README's figure block under ``root``; return both.

    Everything is read and checked before anything is written, so a bad run folder leaves both
    files as they were.
    """
    runs = load_runs(root / "docs" / "runs")
    caches = [load_cache_run(f) for f in sorted((root / "docs" / "runs").iterdir())
              if f.is_dir() and is_cache_run(f)]
    sweeps = [load_accuracy_run(f) for f in sorted((root / "docs" / "runs").iterdir())
              if f.is_dir() and is_accuracy_run(f)]
    windows = [load_window_run(f) for f in sorted((root / "docs" / "runs").iterdir())
               if f.is_dir() and is_window_run(f)]
    results = root / "docs" / "results.md"
    readme = root / "README.md"
    if not readme.is_file():
        raise GameError(f"{readme}: not found (give the checkout's root: bench --report ROOT)")
    page = results_page(runs, results.parent, caches, sweeps, windows)
    text = replace_block(readme.read_text(encoding="utf-8"), readme_block(runs, readme.parent),
                         readme)
    outputs.write_bytes(results, page.encode())
    outputs.write_bytes(readme, text.encode())
    return [results, readme]


def load_runs(folder: Path) -> list[RecordedRun]:
    """Every recorded run under ``folder``, by name."""
    if not folder.is_dir():
        raise GameError(f"{folder}: no recorded runs (record one with python -m game bench "
                        f"--out {folder}/NAME)")
    runs = [load_run(f) for f in sorted(folder.iterdir())
            if f.is_dir() and not any(is_suite(f) for is_suite in
                                      (is_cache_run, is_accuracy_run, is_window_run))]
    if not runs:
        raise GameError(f"{folder}: no recorded runs (record one with python -m game bench "
                        f"--out {folder}/NAME)")
    return runs


def load_run(folder: Path) -> RecordedRun:
    """One run folder; a missing or garbled file is refused in one line."""
    csv_path, record_path = folder / "bench.csv", folder / "run.json"
    for path in (csv_path, record_path):
        if not path.is_file():
            raise GameError(f"{folder}: not a recorded run: no {path.name} (python -m game "
                            f"bench --out {folder} writes both)")
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise GameError(f"{record_path}: not a run record ({error})") from None
    if not isinstance(record, dict):
        raise GameError(f"{record_path}: not a run record (not a JSON object)")
    missing = [k for k in RECORD_KEYS if not isinstance(record.get(k), str)]
    if missing:
        raise GameError(f"{record_path}: not a run record (no {', '.join(missing)})")
    rows = [r for r in read_rows(csv_path) if r.get("status") == "ok"]
    if not rows:
        raise GameError(f"{csv_path}: no finished runs in it")
    if all(math.isnan(row_number(r, "total_ms_median")) for r in rows):
        raise GameError(f"{csv_path}: no frame times in it (total_ms_median)")
    return RecordedRun(folder.name, folder, record, rows)


# --- figures -------------------------------------------------------------------------------------

def size_of(row: dict) -> str:
    return f"{row['width']}x{row['height']}"


def label(row: dict, drop: str = "") -> str:
    """The run's parameters as the bench names them, without ``drop``; "defaults" if none."""
    params = [p for p in row["run"].split("|")[2].split(",")
              if p != "defaults" and not (drop and p.startswith(f"{drop}="))]
    return ", ".join(params) or "defaults"


def clumping_pairs(rows: list[dict]) -> list[tuple[dict, dict]]:
    """(world, light) rows of ``clumped`` that differ only in ``clumping``, in CSV order."""
    found: dict[tuple, dict[str, dict]] = {}
    for r in rows:
        if r["method"] != "clumped" or r["group"] not in COMPARED_GROUPS:
            continue
        key = (r["scene"], size_of(r), r.get(RERENDER, ""),
               *(r.get(k, "") for k in PARAM_KEYS if k != "clumping"))
        found.setdefault(key, {}).setdefault(r.get("clumping", ""), r)
    return [(pair["world"], pair["light"]) for pair in found.values()
            if "world" in pair and "light" in pair]


def one_map_comparisons(rows: list[dict]) -> list[tuple[dict, list[dict]]]:
    """Per scene and size: clumped at its defaults, and every ``single`` run beside it. Only the
    scenes the bench compares methods on: the stability scenes test where methods fail."""
    out = []
    for r in rows:
        if r["method"] == "clumped" and is_default(r) and r["group"] in COMPARED_GROUPS:
            singles = [s for s in rows if s["method"] == "single" and s["scene"] == r["scene"]
                       and size_of(s) == size_of(r)]
            if singles:
                singles.sort(key=lambda s: row_number(s, "single_resolution"))
                out.append((r, singles))
    return out


def tally(pairs: list[tuple[float, float]]) -> tuple[int, int, int]:
    """How many pairs (a, b) have a < b, b < a, and neither (equal or unmeasured)."""
    a = sum(1 for x, y in pairs if x < y)
    b = sum(1 for x, y in pairs if y < x)
    return a, b, len(pairs) - a - b


def counted(what: str, pairs: list[tuple[float, float]], first: str, second: str) -> str:
    """One computed clause: which of two sides is lower in how many of the pairs."""
    a, b, rest = tally(pairs)
    tail = f", neither in {rest}" if rest else ""
    return f"{what}: {first} lower in {a} of {len(pairs)}, {second} in {b}{tail}"


def plural(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


# --- formatting ----------------------------------------------------------------------------------

def ms(value: float) -> str:
    if math.isnan(value):
        return NO_FIGURE
    return f"{value:.2f}" if value < 10 else f"{value:.1f}"


def pct(value: float) -> str:
    return NO_FIGURE if math.isnan(value) else f"{100 * value:.2f}%"


def ratio(a: float, b: float) -> str:
    return NO_FIGURE if math.isnan(a) or math.isnan(b) or b <= 0 else f"{a / b:.2f}"


def count(value: float) -> str:
    return NO_FIGURE if math.isnan(value) else f"{value:.0f}"


def share(value: float) -> str:
    """A mean or ratio near one: maps per pixel, footprint overlap."""
    return NO_FIGURE if math.isnan(value) else f"{value:.2f}"


def frame(row: dict) -> str:
    """The frame's median ms, with the spread of the repeats' medians where it was repeated."""
    text = ms(row_number(row, "total_ms_median"))
    repeats, spread = row_number(row, "repeats"), row_number(row, "total_ms_spread")
    if repeats > 1 and not math.isnan(spread):
        text += f" ({100 * spread:.0f}%)"
    return text


def table(head: list[str], body: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return lines + ["| " + " | ".join(cells) + " |" for cells in body] + [""]


def header(run: RecordedRun, here: Path) -> list[str]:
    """The line that heads every table of a run: command, renderer, date, code and folder."""
    rec = run.record
    code = ""
    if isinstance(rec.get("commit"), str) and rec["commit"]:
        code = f"; code `{rec['commit'][:10]}`" + (" with local changes" if rec.get("dirty")
                                                     else "")
    where = Path(os.path.relpath(run.folder, here)).as_posix()
    clock = "; timed by one thread's CPU time" if rec.get("clock") == THREAD_CLOCK else ""
    return [f"Run [`{run.name}`]({where}/run.json): `{rec['command']}`; "
            f"{rec['renderer']}, OpenGL {rec['version']}{clock}; {rec['date']}{code}.", ""]


# --- the page ------------------------------------------------------------------------------------

INTRO = """\
The answers to the two questions of "Some Ideas on Shadow Algorithms" come first, then every
recorded run. Every figure below is computed from the recorded runs in [runs/](runs/) by
`python -m game bench --report`, which also writes the table in the README. Each
table is headed by the run it comes from: the command that recorded it, the renderer, the date
(UTC) and the code. To add or refresh a figure, record a run and regenerate this page; do not
edit it by hand.

How to read the figures:

- Milliseconds are medians of a run's timed frames, per pass, timed with the clock the bench
  chose for the renderer (on Mesa llvmpipe the CPU clock around `glFinish`). A run "timed by
  one thread's CPU time" used `--clock cpu-thread`: llvmpipe rasterised in one thread, whose CPU
  time other processes' load does not move; its milliseconds are one core's work. Where a run was
  recorded with `--repeat N`, the runs of a scene took turns, and the frame time is the median of
  the N medians, followed by its spread: (slowest - fastest) / median, in brackets.
- A machine's speed moves between runs and while others share it, so compare methods within one
  run (ratios), not milliseconds across runs.
- The shadow error is the share of the pixels that the method or the Embree reference shadows
  on which the two disagree (one minus the intersection over union of the two shadow masks),
  pooled over the run's error frames. It does not depend on the machine's speed: the same
  code, scene, size and error frames give the same error.
- "Shadow maps" is the frame's map passes (cached clump maps and the characters' maps);
  "camera" is triangle culling plus shading.

Why the methods behave as they do is in the design notes:
[architecture](design/architecture.md), [crowds](design/crowds.md),
[the depth array](design/depth-array.md), [many lights](design/lights.md) and
[view-sized maps](design/view-budget.md).
"""

RECORDING = """\
## Recording a run

```bash
pip install -e ".[bench]"       # matplotlib, tqdm and embreex, the reference
python -m game bench --list ...  # the runs a command would make
python -m game bench --out docs/runs/NAME ...
python -m game bench --report    # this page and the README's table
```

The bench writes `bench.csv` (one row per run), `summary.json`, `run.json` and `charts/` into
its folder; a rerun into the same folder keeps the rows it has. Only the CSV, `run.json` and
the charts this page shows need to be kept.
"""


def results_page(runs: list[RecordedRun], here: Path, caches: list[SuiteRun] = (),
                 sweeps: list[SuiteRun] = (), windows: list[SuiteRun] = ()) -> str:
    """The whole of ``docs/results.md``: the two questions first, the window's frame rate,
    the soft-shadow cache question, the random scenes, then every run."""
    lines = ["# Results", "", INTRO]
    lines += question_one(runs, here) + question_two(runs, here)
    lines += shading_section(runs, here, header)
    for window in windows:
        lines += window_section(window, here, header, table)
    for cache in caches:
        lines += cache_section(cache, here)
    for sweep in sweeps:
        lines += accuracy_section(sweep, here)
    lines += ["## Every recorded run", ""]
    for run in runs:
        lines += run_section(run, here)
    return "\n".join(lines) + "\n" + RECORDING


def question_one(runs: list[RecordedRun], here: Path) -> list[str]:
    """Q1 of the paper: the clumped method with world-space and light-space clumps."""
    lines = ["## Question 1: clump in world space or in light space?", "",
             "`clumped` with `clumping=world` against `clumping=light`, every other setting "
             "equal (the default is light). Figures are world / light.", ""]
    pairs = [(run, clumping_pairs(run.rows)) for run in runs]
    every = [p for _, found in pairs for p in found]
    if not every:
        return lines + ["No recorded run compares the two; record one with "
                        "`python -m game bench --methods clumped --param clumping=world,light "
                        "--out docs/runs/NAME`.", ""]
    lines += ["**What the figures say.** Of {} in {}: {}; {}; {}.".format(
        plural(len(every), "pair"), plural(len({w["scene"] for w, _ in every}), "scene"),
        counted("error", [(row_number(w, "error"), row_number(li, "error"))
                          for w, li in every], "world", "light"),
        counted("frame", [(row_number(w, "total_ms_median"), row_number(li, "total_ms_median"))
                          for w, li in every], "world", "light"),
        counted("map passes", [(maps_ms(w), maps_ms(li)) for w, li in every],
                "world", "light")), ""]
    head = ["scene", "size", "other settings", "frame ms", "shadow maps ms", "error",
            "static texels per metre", "footprint overlap", "maps per pixel"]
    for run, found in pairs:
        if not found:
            continue
        body = [[w["scene"], size_of(w), label(w, drop="clumping"),
                 f"{frame(w)} / {frame(li)}", f"{ms(maps_ms(w))} / {ms(maps_ms(li))}",
                 f"{pct(row_number(w, 'error'))} / {pct(row_number(li, 'error'))}",
                 f"{count(row_number(w, 'static_texels_per_metre'))} / "
                 f"{count(row_number(li, 'static_texels_per_metre'))}",
                 f"{share(row_number(w, 'footprint_overlap'))} / "
                 f"{share(row_number(li, 'footprint_overlap'))}",
                 f"{share(row_number(w, 'maps_per_fragment'))} / "
                 f"{share(row_number(li, 'maps_per_fragment'))}"] for w, li in found]
        lines += header(run, here) + table(head, body)
    lines += ["Static texels per metre is the median density of the clump maps; the footprint "
              "overlap is the summed light-space area of the clump maps over the area of their "
              "union (1: no overlap). Why the clumpings differ: "
              "[the architecture](design/architecture.md#clumping-world-space-or-light-space).",
              ""]
    return lines


def question_two(runs: list[RecordedRun], here: Path) -> list[str]:
    """Q2 of the paper: clumped (many small maps) against ``single`` (one large map)."""
    lines = ["## Question 2: many small maps or one large one?", "",
             "`clumped` at its defaults (cached clump maps and one map per character) against "
             "`single`, one map over every caster redrawn each frame, at each resolution "
             "recorded; the last column is the run's frame over clumped's.", ""]
    found = [(run, one_map_comparisons(run.rows)) for run in runs]
    every = [(c, s) for _, comps in found for c, singles in comps for s in singles]
    if not every:
        return lines + ["No recorded run has both; record one with `python -m game bench "
                        "--methods clumped,single --out docs/runs/NAME`.", ""]
    defaults = [(c, s) for c, s in every if is_default(s)]
    lines += ["**What the figures say.** Clumped against every `single` run ({} in {}): {}; "
              "{}. Against `single` at its defaults: {}; {}.".format(
                  plural(len(every), "run"), plural(len({c["scene"] for c, _ in every}), "scene"),
                  _versus("frame", "total_ms_median", every),
                  _versus("error", "error", every),
                  _versus("frame", "total_ms_median", defaults),
                  _versus("error", "error", defaults)), ""]
    head = ["scene", "size", "method", "settings", "maps", "maps drawn a frame", "shadow MiB",
            "frame ms", "shadow maps ms", "camera ms", "error", "frame / clumped's"]
    for run, comps in found:
        if not comps:
            continue
        body = []
        for c, singles in comps:
            t = row_number(c, "total_ms_median")
            body += [[r["scene"], size_of(r), f"`{r['method']}`", label(r),
                      count(row_number(r, "maps_total")), count(row_number(r, "maps_rendered")),
                      count(row_number(r, "shadow_memory_mib")), frame(r), ms(maps_ms(r)),
                      ms(camera_ms(r)), pct(row_number(r, "error")),
                      ratio(row_number(r, "total_ms_median"), t)] for r in (c, *singles)]
        lines += header(run, here) + table(head, body)
    lines += ["Why many small maps win where they are cached, and what each extra map costs: "
              "[the architecture](design/architecture.md#many-small-maps-or-one-large-one), "
              "[the depth array](design/depth-array.md), [depth bounds](design/depth-bounds.md) "
              "and [crowds](design/crowds.md).", ""]
    return lines


def _versus(what: str, key: str, pairs: list[tuple[dict, dict]]) -> str:
    return counted(what, [(row_number(c, key), row_number(s, key)) for c, s in pairs],
                   "clumped", "`single`")


def run_section(run: RecordedRun, here: Path) -> list[str]:
    """Every finished row of one run, and up to two of its charts."""
    lines = [f"### {run.name}", ""] + header(run, here)
    head = ["scene", "size", "method", "settings", "frame ms", "p95 ms", "shadow maps ms",
            "camera ms", "error", "maps drawn a frame", "maps per pixel",
            "map records per pixel", "shadow MiB"]
    body = [[r["scene"], size_of(r), f"`{r['method']}`", label(r), frame(r),
             ms(row_number(r, "total_ms_p95")), ms(maps_ms(r)), ms(camera_ms(r)),
             pct(row_number(r, "error")), count(row_number(r, "maps_rendered")),
             share(row_number(r, "maps_per_fragment")),
             share(row_number(r, "map_candidates_per_fragment")),
             count(row_number(r, "shadow_memory_mib"))] for r in run.rows]
    lines += table(head, body)
    for chart in sorted((run.folder / "charts").glob("pareto_*.png"))[:CHARTS_PER_RUN]:
        where = Path(os.path.relpath(chart, here)).as_posix()
        lines += [f"![{chart.stem} of run {run.name}]({where})", "",
                  f"*`{chart.stem}`: the shadow error against the frame time, one point per run "
                  "of the scene; the large outlined markers are the methods at their defaults.*",
                  ""]
    return lines


# --- the README's block --------------------------------------------------------------------------

WINDOW_SIZE = "960x540"  # the walkaround window's: the size the README's figures are at
CLOCK_MARK = {THREAD_CLOCK: ", one thread's CPU time"}  # after a run's link: what its ms are


def readme_block(runs: list[RecordedRun], here: Path) -> str:
    """The README's headline: clumped at its defaults against ``single`` at its defaults, at
    the window's size, on the shipped main scenes and the real corpus, a row per scene (the
    first run that has it)."""
    head = ["scene", "size", "clumped: frame ms, error", "`single`: frame ms, error",
            "frame, clumped / `single`", "run"]
    body, seen = [], set()
    # At the window's size where any run has it, else at every size recorded.
    sizes = {size_of(c) for run in runs for c, _ in one_map_comparisons(run.rows)}
    for run in runs:
        for c, singles in one_map_comparisons(run.rows):
            if ((WINDOW_SIZE in sizes and size_of(c) != WINDOW_SIZE)
                    or c["group"] not in ("main", "real") or c["scene"] in seen):
                continue
            seen.add(c["scene"])
            for s in (s for s in singles if is_default(s)):
                where = Path(os.path.relpath(run.folder, here)).as_posix()
                body.append([c["scene"], size_of(c),
                             f"{ms(row_number(c, 'total_ms_median'))}, "
                             f"{pct(row_number(c, 'error'))}",
                             f"{ms(row_number(s, 'total_ms_median'))}, "
                             f"{pct(row_number(s, 'error'))}",
                             ratio(row_number(c, "total_ms_median"),
                                   row_number(s, "total_ms_median")),
                             f"[{run.name}]({where}/run.json)" + CLOCK_MARK.get(
                                 run.record.get("clock", ""), "")])
    lines = [BEGIN, ""]
    lines += table(head, body) if body else ["No recorded run compares clumped with single.", ""]
    lines += ["*Generated by `python -m game bench --report` from the recorded runs; their "
              "commands, renderer and dates are on [the results page](docs/results.md).*", "",
              END]
    return "\n".join(lines)


def replace_block(text: str, block: str, path: Path) -> str:
    """``text`` with its one figure block replaced by ``block``; the rest kept as it is."""
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start or text.count(BEGIN) != 1 or text.count(END) != 1:
        raise GameError(f"{path}: no single {BEGIN} ... {END} block for the figures")
    return text[:start] + block + text[end + len(END):]
