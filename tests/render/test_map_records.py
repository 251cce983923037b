"""The map records as the lookup reads them: each member of a ShadowMaps record in its texel,
exact, and the code that holds kind and flags read back as shaders/shadow.glsl reads it."""

from __future__ import annotations

import numpy as np

from game.gpu import blocks
from game.render.map_records import (
    RECORD_BOUNDS,
    RECORD_DEPTH,
    RECORD_FLAG_CODES,
    RECORD_LAYER,
    RECORD_TEXELS,
    RECORD_VIEW_PROJ,
    record_rows,
)
from game.shadows.plan import KIND_CASCADE, KIND_CHARACTER, KIND_CLUMP, KIND_FALLBACK


def _block(n: int) -> np.ndarray:
    rng = np.random.default_rng(3)
    block = np.zeros(n, blocks.MAP_DTYPE)
    for name in ("view_proj", "bounds", "uv_offset"):
        block[name] = rng.normal(size=block[name].shape).astype(np.float32)
    for name in ("texel", "uv_scale", "near", "inv_depth_range"):
        block[name] = rng.random(n).astype(np.float32)
    block["layer"] = rng.integers(0, 2048, n)
    block["kind"] = rng.choice([KIND_CLUMP, KIND_CHARACTER, KIND_CASCADE, KIND_FALLBACK], n)
    block["flags"] = rng.integers(0, (blocks.MAP_FRESH | blocks.MAP_BOUNDED) + 1, n)
    return block


def test_every_member_the_lookup_reads_is_in_its_texel_exactly():
    block = _block(50)
    rows = record_rows(block)
    assert rows.shape == (50, RECORD_TEXELS, 4) and rows.dtype == np.float32
    assert np.array_equal(rows[:, RECORD_BOUNDS], block["bounds"])
    depth = rows[:, RECORD_DEPTH]
    for k, name in enumerate(("near", "inv_depth_range", "texel", "uv_scale")):
        assert np.array_equal(depth[:, k], block[name])
    layer = rows[:, RECORD_LAYER]
    assert np.array_equal(layer[:, :2], block["uv_offset"])
    assert np.array_equal(layer[:, 2].astype(np.int64), block["layer"])
    # The matrix's texels are its columns, as GL reads the block's column-major matrix.
    assert np.array_equal(rows[:, RECORD_VIEW_PROJ:], block["view_proj"])


def test_kind_and_flags_come_back_from_their_code():
    block = _block(200)
    code = record_rows(block)[:, RECORD_LAYER, 3].astype(np.int64)
    assert np.array_equal(code // RECORD_FLAG_CODES, block["kind"])
    assert np.array_equal(code % RECORD_FLAG_CODES, block["flags"])
    assert set(block["flags"]) == {0, 1, 2, 3}  # every combination of the flags was held
