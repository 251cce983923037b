"""What a soft-shadow trace returns: the per-point records of the pass's Results buffer
(``TRACE_RESULT_DTYPE``) decoded into a visibility image and the counters' images."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from game.gpu import blocks
from game.soft.methods import TRACED_METHODS, TraceSettings

COUNTERS = ("ray_triangle_tests", "triangle_triangle_tests", "voxels_visited", "candidates",
            "overflows", "bytes_triangles", "bytes_cells", "bytes_candidates", "dispatches")
# Memory traffic per point, by what is read: the Triangles buffer, the structure (top table,
# sub-grid table, leaf offsets and ids), and the candidate state (voxel-cache's table and pool,
# tri-cache's per-triangle words; read and written). 64-bit counts, kept as two 32-bit words.
BYTE_COUNTERS = ("bytes_triangles", "bytes_cells", "bytes_candidates")


@dataclass
class TraceResult:
    """What one trace produced; images have row 0 at the top."""

    visibility: np.ndarray            # (H, W) float32, NaN where no geometry
    counters: dict[str, np.ndarray]   # per counter (H, W): uint32, the byte counts uint64
    ms: dict[str, float] = field(default_factory=dict)
    truncated: int = 0                # points whose work llvmpipe's loop budget cut short
    # Samples per dispatch of the point that needed the most dispatches (the samples when none
    # was split; for analytic on a segment, the samples asked for).
    samples_per_dispatch: int = 0
    rounds: int = 0                   # dispatches the trace took
    step_budget: int = 0              # loop iterations each point was given per dispatch
    # The raster methods' map passes this frame, by name (game/soft/light_maps.py MapCounts).
    maps: dict[str, int] = field(default_factory=dict)

    @property
    def covered(self) -> np.ndarray:
        return np.isfinite(self.visibility)

    def means(self) -> dict[str, float]:
        """Mean of every counter per shaded point, and ``bytes_total``."""
        n = int(self.covered.sum())
        out = {k: (float(v[self.covered].sum()) / n if n else 0.0)
               for k, v in self.counters.items()}
        if all(k in out for k in BYTE_COUNTERS):
            out["bytes_total"] = sum(out[k] for k in BYTE_COUNTERS)
        return out


def decode_results(raw: np.ndarray, settings: TraceSettings, mode: int, ms: dict[str, float],
                   rounds: int, budget: int) -> TraceResult:
    """The trace's result from the shader's per-point records ``raw`` (H, W), row 0 at the
    top: visibility NaN where no geometry, the byte counters joined into 64 bits."""
    vis = raw["visibility"].astype(np.float32)
    vis = np.where(vis < 0.0, np.nan, vis).astype(np.float32)
    counters = {}
    for name in COUNTERS:
        v = raw[name]
        if name in BYTE_COUNTERS:
            v = v[..., 0].astype(np.uint64) + (v[..., 1].astype(np.uint64) << np.uint64(32))
        counters[name] = np.ascontiguousarray(v)
    covered = np.isfinite(vis)
    most = int(counters["dispatches"][covered].max()) if covered.any() else 1
    exact = not TRACED_METHODS[settings.method].sampled and mode == blocks.TRACE_LIGHT_SEGMENT
    per_dispatch = settings.samples if exact else -(-settings.samples // max(1, most))
    return TraceResult(visibility=vis, counters=counters, ms=ms,
                       truncated=int(raw["truncated"][covered].sum()),
                       samples_per_dispatch=per_dispatch, rounds=rounds, step_budget=budget)
