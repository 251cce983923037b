"""The benchmark's CSV: one row per run, rewritten atomically after every run."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from game.app import outputs
from game.bench.runs import COLUMNS


def read_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def write_rows(path: Path, rows: list[dict]) -> None:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, extrasaction="ignore",
                            lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row.get(k, "")) for k in COLUMNS})
    outputs.write_bytes(path, buf.getvalue().encode())


def _cell(value):
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.10g}"
    return "" if value is None else value


def row_number(row: dict, key: str) -> float:
    """A CSV row's number under ``key``; NaN where it is empty or not a number."""
    try:
        return float(row.get(key, ""))
    except (TypeError, ValueError):
        return float("nan")
