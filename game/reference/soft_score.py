"""The soft check: a dump's traced ``soft`` visibility against stratified Embree samples of the
linear light, as the soft sweep (game/bench/soft_sweep.py) scores its methods.

Every dumped point that sees geometry casts ``SOFT_REFERENCE_SAMPLES`` stratified rays toward the
segment with Embree (game/reference/soft.py), from the dumped position pushed off along the
dumped normal by the tracer's rule. The same rays are cast again from half and twice that
offset: a point whose reference changes by more than one sample is left out and counted, as the
hard check leaves out its pixels (game/reference/offsets.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from game.reference.hard import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE, load_frame, load_geometry
from game.reference.offsets import OFFSET_PROBE
from game.reference.soft import EmbreeOccluder, ray_origins, stratified_reference

# As many as the soft sweep's reference: its RMSE and this one measure the same thing.
SOFT_REFERENCE_SAMPLES = 1024
# A point is "off" when its visibility differs from the reference's by more than this share of
# the light: a tenth of the segment is a shadow edge visibly in the wrong place.
OFF_BY = 0.1
# A point is left out when its reference changes with the offset by more than this many of its
# samples: a single ray that slips between two triangles of a shared edge flips from almost any
# start point, which says nothing about the offset (on the courtyard most changed points are
# such one-ray flips; a contact or a crease changes several).
OFFSET_TOLERANCE_SAMPLES = 1


def score_soft(soft: np.ndarray, position: np.ndarray, normal: np.ndarray, mesh,
               a, b, samples: int = SOFT_REFERENCE_SAMPLES) -> dict[str, Any]:
    """RMSE of ``soft`` against the stratified Embree reference of the segment ``a``-``b``.

    Returns ``{"rmse", "off", "off_share", "points", "left_out_offset", "reference_samples"}``
    (``off``: points off by more than :data:`OFF_BY`; ``off_share``: ``off / max(1, points)``),
    and the (H, W) images ``reference`` (NaN where not cast), ``considered_mask`` and
    ``offset_mask``.
    """
    has_geometry = (np.isfinite(position).all(axis=-1) & np.isfinite(normal).all(axis=-1)
                    & np.isfinite(soft))
    reference = np.full(soft.shape, np.nan)
    offset_mask = np.zeros(soft.shape, bool)
    if has_geometry.any() and len(mesh.faces):
        p = position[has_geometry].astype(np.float64)
        n = normal[has_geometry].astype(np.float64)
        corners = np.vstack([mesh.bounds, p.min(axis=0), p.max(axis=0)])
        diagonal = float(np.linalg.norm(corners.max(axis=0) - corners.min(axis=0)))
        occluder = EmbreeOccluder(mesh)
        # One seed for all three: the same sample points, so only the offset differs.
        cast = [stratified_reference(
            occluder, ray_origins(p, n, scale * RAY_OFFSET_SCENE * diagonal,
                                  scale * RAY_OFFSET_DISTANCE), n, a, b, samples, seed=0)
            for scale in (1.0, 1.0 / OFFSET_PROBE, OFFSET_PROBE)]
        reference[has_geometry] = cast[0]
        change = np.maximum(np.abs(cast[1] - cast[0]), np.abs(cast[2] - cast[0]))
        offset_mask[has_geometry] = change * samples > OFFSET_TOLERANCE_SAMPLES + 0.5
    elif has_geometry.any():  # nothing to cast against: the whole light is seen
        reference[has_geometry] = _unoccluded(position, normal, has_geometry, a, b, samples)
    considered = has_geometry & ~offset_mask
    diff = soft[considered].astype(np.float64) - reference[considered]
    points = int(considered.sum())
    off = int((np.abs(diff) > OFF_BY).sum())
    return {"rmse": float(np.sqrt(np.mean(diff**2))) if points else 0.0, "off": off,
            "off_share": off / max(1, points), "points": points,
            "left_out_offset": int(offset_mask.sum()), "reference_samples": samples,
            "reference": reference, "considered_mask": considered, "offset_mask": offset_mask}


def _unoccluded(position, normal, where, a, b, samples: int) -> np.ndarray:
    """The share of stratified samples above each point's horizon, with no occluder at all."""
    t = (np.arange(samples) + 0.5) / samples
    targets = np.asarray(a, float)[None, :] + t[:, None] * (np.asarray(b, float) - a)[None, :]
    p, n = position[where].astype(np.float64), normal[where].astype(np.float64)
    return (np.einsum("psk,pk->ps", targets[None] - p[:, None], n) > 0).mean(axis=1)


def score_soft_dump(npz_path: str | Path, a, b,
                    samples: int = SOFT_REFERENCE_SAMPLES) -> dict[str, Any]:
    """:func:`score_soft` of one ``--dump`` frame that holds ``soft``; every object of its glb,
    floors included, occludes, as in the tracer. Adds ``method``, the dumped ``soft``."""
    npz_path = Path(npz_path)
    frame = load_frame(npz_path)
    for key in ("position", "normal", "soft"):
        if key not in frame:
            raise ValueError(f"{npz_path.name}: no {key!r} array")
    mesh = load_geometry(npz_path.with_suffix(".glb"))
    scores = score_soft(frame["soft"], frame["position"], frame["normal"], mesh, a, b, samples)
    return {**scores, "method": frame["soft"]}


def dump_holds_soft(npz_path: str | Path) -> bool:
    """Whether a dump holds ``soft`` (``trace --dump``, ``capture --soft --dump``), read from
    its list of arrays alone."""
    with np.load(npz_path, allow_pickle=False) as data:
        return "soft" in data.files
