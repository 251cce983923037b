"""Reading a recorded suite run (the cache suite's, the accuracy sweep's): its ``run.json`` and
its CSV, refused in one line where either is missing or garbled."""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

from game.errors import GameError


@dataclass(frozen=True)
class SuiteRun:
    """One recorded suite run's folder, its record (``run.json``) and its rows."""

    name: str
    folder: Path
    record: dict
    rows: list[dict]


def read_suite_run(folder: Path, csv_name: str, columns: tuple[str, ...], what: str,
                   suite: str) -> SuiteRun:
    """The ``suite`` run in ``folder`` (``what`` names it in messages); its CSV must hold
    ``columns``."""
    path, record_path = folder / csv_name, folder / "run.json"
    if not record_path.is_file():
        raise GameError(f"{folder}: not a recorded {what}: no run.json (python -m game bench "
                        f"--suite {suite} --out {folder} writes both)")
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except (UnicodeDecodeError, json.JSONDecodeError, csv.Error) as error:
        raise GameError(f"{folder}: not a recorded {what} ({error})") from None
    if not isinstance(record, dict) or not all(isinstance(record.get(k), str)
                                               for k in ("command", "date")):
        raise GameError(f"{record_path}: not a run record (no command or date)")
    if not rows or any(c not in rows[0] for c in columns):
        raise GameError(f"{path}: not the {suite} suite's columns")
    return SuiteRun(folder.name, folder, record, rows)
