"""The benchmark's CSV: one row per run, rewritten atomically after every run."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from game.app import outputs
from game.bench.runs import COLUMNS
from game.errors import GameError


def read_rows(path: Path) -> list[dict]:
    """The finished rows of an earlier run. A damaged file (not the bench's columns) is refused
    in one line; a row cut short, or with no ``status``, is dropped, so the rerun measures it
    again."""
    if not path.exists():
        return []
    try:
        with path.open(newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            header = reader.fieldnames or []
            if header[:2] != list(COLUMNS[:2]) or not set(header) <= set(COLUMNS):
                raise GameError(f"{path}: not a bench CSV (its header is not the bench's "
                                "columns); move it away or choose another --out")
            return [row for row in reader
                    if None not in row and None not in row.values() and row.get("status")
                    and row.get("run")]
    except (UnicodeDecodeError, csv.Error) as error:
        raise GameError(f"{path}: not a bench CSV ({error})") from None


def write_table(path: Path, rows: list[dict], fields: list[str]) -> None:
    """``rows`` under the header ``fields``, written whole (the soft sweep's and the cache
    suite's tables)."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=fields)
    writer.writeheader()
    writer.writerows(rows)
    outputs.write_bytes(path, buf.getvalue().encode())


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


def maps_ms(row: dict) -> float:
    """The shadow-map passes of a run's frames: the cached statics' and the characters',
    medians."""
    return row_number(row, "shadow_static_ms_median") + row_number(row, "shadow_dynamic_ms_median")


def camera_ms(row: dict) -> float:
    """The camera pass of a run's frames: triangle culling plus shading, medians."""
    return row_number(row, "cull_ms_median") + row_number(row, "shade_ms_median")
