"""A tiny fake bench run that the results page's tests share: its record, its rows and a README
with the figure block."""

from __future__ import annotations

import json
from pathlib import Path

from game.bench.report import BEGIN, END
from game.bench.rows import write_rows

RECORD = {"command": "python -m game bench --scenes courtyard --repeat 3 --out docs/runs/fake",
          "renderer": "llvmpipe (LLVM 15.0.6, 256 bits)", "version": "4.5 (Core Profile)",
          "date": "2026-01-02 03:04 UTC", "commit": "0123456789abcdef", "dirty": False}
README = f"# A project\n\nWords before.\n\n{BEGIN}\nold figures\n{END}\n\nWords after.\n"


def row(method: str, params: str, total: float, error: float, **more) -> dict:
    """One bench CSV row of the courtyard at 320x180; every pass but the total is fixed."""
    return {"run": f"courtyard|{method}|{params}|320x180", "scene": "courtyard", "group": "main",
            "method": method, "clumping": more.pop("clumping", "light"), "clump_count": "",
            "single_resolution": more.pop("single_resolution", 4096), "width": 320,
            "height": 180, "total_ms_median": total, "total_ms_p95": total * 1.5,
            "shadow_static_ms_median": 0.5, "shadow_dynamic_ms_median": 1.5,
            "cull_ms_median": 2.0, "shade_ms_median": 3.0, "error": error,
            "maps_rendered": 7, "maps_total": 10 if method == "clumped" else 1,
            "shadow_memory_mib": 64, "status": "ok", **more}


ROWS = [
    row("clumped", "defaults", 10.0, 0.002, repeats=3, total_ms_spread=0.125,
        static_texels_per_metre=145.2),
    row("clumped", "clumping=world", 12.0, 0.004, clumping="world", repeats=3,
        total_ms_spread=0.25, static_texels_per_metre=107.9),
    row("single", "defaults", 30.0, 0.005, repeats=3, total_ms_spread=0.05),
    row("single", "single_resolution=1024", 8.0, 0.02, single_resolution=1024, repeats=3,
        total_ms_spread=0.05),
]


def fake_checkout(root: Path) -> Path:
    """``root`` made a checkout with one recorded run, ``docs/runs/fake``, and a README with a
    figure block; returns it."""
    folder = root / "docs" / "runs" / "fake"
    folder.mkdir(parents=True)
    write_rows(folder / "bench.csv", ROWS)
    (folder / "run.json").write_text(json.dumps(RECORD))
    (root / "README.md").write_text(README)
    return root
