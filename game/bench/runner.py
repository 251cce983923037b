"""The speed-versus-accuracy benchmark: methods x parameters x scenes along a fixed camera path.

Each run (game/bench/runs.py) renders one scene with one method and one parameter set and writes
one CSV row (game/bench/measure.py says what a run measures). The CSV is rewritten atomically
after every run (game/bench/rows.py): an interrupted bench keeps every finished row, and a rerun
skips the rows it already has. Charts: game/bench/charts.py; acceptance figures:
game/bench/acceptance.py.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import NoReturn

from game.app import interrupts, outputs
from game.bench import charts
from game.bench.acceptance import acceptance
from game.bench.measure import interleaved_timings, run_one
from game.bench.rows import read_rows, write_rows
from game.bench.runs import BenchOptions, BenchScene, plan_runs
from game.errors import GameError
from game.gpu import context
from game.scene import Scene, parse_scene
from game.scene.mesh_files import regular_file


def run(opts: BenchOptions, ctx=None, command: str = "") -> dict:
    """Run the sweep (skipping finished rows), then write the charts; returns a summary.

    ``ctx``: a GL context to use (and leave open); by default one is made and released here.
    ``command``: the command line, recorded in ``OUT/run.json`` for the report
    (game/bench/report.py).
    """

    _need_extras()
    check_outputs(opts.out)
    opts.out.mkdir(parents=True, exist_ok=True)
    (opts.out / "scenes").mkdir(exist_ok=True)
    clean(opts.out)
    csv_path = opts.out / "bench.csv"
    if csv_path.exists():  # read back to resume: checked again right before the read
        regular_file(csv_path, str(csv_path), _refuse)
    rows = read_rows(csv_path)
    own = ctx is None
    ctx = context.create_headless() if own else ctx
    try:
        runs = plan_runs(opts, int(ctx.info["GL_MAX_TEXTURE_SIZE"]))
        write_run_record(opts.out, command, context.describe(ctx), opts.clock)
        # A row of a scene whose text has changed since (or another file of the same name) is
        # measured again, not kept.
        current = {b.key: b.sha256 for b, _ in runs}
        rows = [r for r in rows if r.get("scene_sha256") in ("", None)
                or r["scene_sha256"] == current.get(r["scene"], r["scene_sha256"])]
        done = {r["run"] for r in rows}
        todo = [(b, s) for b, s in runs if s.run_id(opts.size) not in done]
        opts.log(f"bench: {len(runs)} runs, {len(runs) - len(todo)} already in {csv_path}, "
                 f"{len(todo)} to go ({context.describe(ctx)['renderer']})")
        bar = _progress(len(todo), opts.progress)
        loaded: tuple[str, Scene] | None = None
        timings: dict = {}
        try:
            for i, (bscene, spec) in enumerate(todo):
                interrupts.check()
                if opts.deadline is not None and time.monotonic() > opts.deadline:
                    opts.log(f"bench: time budget spent; {len(todo) - i} run(s) not made")
                    break
                bar.set_description(f"{bscene.key} {spec.method}")
                if loaded is None or loaded[0] != bscene.key:
                    loaded = (bscene.key, _load(bscene, opts.out / "scenes"))
                    if opts.repeat > 1:
                        bar.set_description(f"{bscene.key}: {opts.repeat} interleaved timings")
                        specs = [sp for b, sp in todo if b.key == bscene.key]
                        timings = interleaved_timings(ctx, loaded[1], specs, opts)
                if opts.repeat > 1:
                    row = run_one(ctx, bscene, loaded[1], spec, opts, timings.pop(spec))
                else:
                    row = run_one(ctx, bscene, loaded[1], spec, opts)
                rows.append(row)
                write_rows(csv_path, rows)
                bar.update(1)
        except BaseException:
            bar.leave = False  # wiped from the terminal: a stopped run ends on its one line
            raise
        finally:
            bar.close()
    finally:
        if own:
            ctx.release()
    written = charts.write_all(rows, opts.out / "charts", log=opts.log)
    summary = acceptance(rows)
    outputs.write_json(opts.out / "summary.json", summary)
    planned = {s.run_id(opts.size) for _, s in runs}
    failed = [(r["run"], str(r["status"])) for r in rows
              if r["run"] in planned and str(r.get("status", "")).startswith("failed")]
    return {"csv": str(csv_path), "rows": len(rows), "charts": [str(p) for p in written],
            "summary": summary, "runs": len(runs), "failed": failed}


def check_outputs(out: Path) -> None:
    """Refuse at once, before any run, an output of the bench that is in the way: bench.csv
    (read back to resume, then rewritten), run.json, summary.json or a chart that is not a
    regular file, and charts/ or scenes/ that are not folders."""
    charts_folder = out / "charts"
    charts_in_way = sorted(charts_folder.glob("*.png")) + sorted(charts_folder.glob("*.svg")) \
        if charts_folder.is_dir() else []
    outputs.check_paths(
        files=[out / "bench.csv", out / "run.json", out / "summary.json", *charts_in_way],
        folders=[out, charts_folder, out / "scenes"])


def check_suite_outputs(out: Path) -> None:
    """``bench --suite gpu``'s files and folders (game/bench/gpu_suite.py), checked before any
    of its parts runs."""
    soft = out / "soft"
    outputs.check_paths(
        files=[out / "summary.json", out / "summary.md", out / "window.json",
               *(soft / name for name in ("soft_sweep.csv", "soft_sweep.json", "soft_sweep.png",
                                          "soft_sweep_counters.png"))],
        folders=[soft])
    check_outputs(out / "hard")


def failure_line(result: dict) -> str:
    """One line for the runs of ``run``'s result that failed: how many, and the first one's
    run and reason (bench.csv holds every reason)."""
    failed = result["failed"]
    run, status = failed[0]
    reason = status.removeprefix("failed: ").splitlines()[0] if status.strip() else status
    return (f"bench: {len(failed)} of {result['runs']} runs failed (the first: {run}: "
            f"{reason}); the status column of {result['csv']} says why for each")


def write_run_record(out: Path, command: str, gl: dict, clock: str = "auto") -> None:
    """``OUT/run.json``: what a reader of the figures needs to redo them - the command, the
    renderer, the timing clock, the date (UTC) and the commit (with ``dirty`` where the tree
    had changes)."""
    record = {"command": command, "renderer": gl["renderer"], "version": gl["version"],
              "clock": clock,
              "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"), **git_commit(out)}
    outputs.write_json(out / "run.json", record)


CODE_PATHS = (":/game", ":/shaders", ":/assets", ":/pyproject.toml")  # what a run's figures rest on


def git_commit(folder: Path) -> dict:
    """The commit of the checkout that holds ``folder``; empty where there is none (a wheel)."""
    try:
        head = subprocess.run(["git", "-C", str(folder), "rev-parse", "HEAD"], text=True,
                              capture_output=True, timeout=10, check=True).stdout.strip()
        # Changed code, not the docs: a run recorded into docs/runs/ changes that folder itself.
        dirty = subprocess.run(["git", "-C", str(folder), "status", "--porcelain",
                                "--untracked-files=no", "--", *CODE_PATHS], text=True,
                               capture_output=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return {}
    return {"commit": head, "dirty": bool(dirty)}


def reference_available() -> bool:
    """Whether the Embree reference (embreex, the ``[bench]`` extra) can score frames."""
    try:
        import embreex  # noqa: F401 - only to learn whether it is installed
    except ImportError:
        return False
    return True


def _load(bscene: BenchScene, folder: Path) -> Scene:
    """Parse a bench scene; generated ones are also written to ``folder`` for ``capture``."""
    if bscene.path is not None:  # a file: its meshes lie beside it
        return parse_scene(bscene.text, source=bscene.path, base_dir=bscene.path.parent)
    path = folder / f"{bscene.key}.toml"
    if not path.exists():
        outputs.write_bytes(path, bscene.text.encode())
    return parse_scene(bscene.text, source=path, base_dir=folder)


def _refuse(problem: str) -> NoReturn:
    raise GameError(problem)


def _need_extras() -> None:
    """Refuse, before anything is written, a bench without its extras (the progress bar and
    the charts)."""
    try:
        import matplotlib  # noqa: F401
        import tqdm  # noqa: F401
    except ImportError as exc:
        raise GameError("bench needs tqdm and matplotlib: pip install -e '.[bench]'") from exc


def _progress(total: int, enabled: bool):
    from tqdm import tqdm
    # None: drawn only on a terminal; a pipe or a log file would keep every redraw.
    return tqdm(total=total, disable=None if enabled else True, unit="run", file=sys.stderr,
                dynamic_ncols=True)


def clean(out: Path) -> None:
    """Remove leftovers of interrupted runs (their temp dump folders)."""
    for tmp in out.glob("bench-*"):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
