"""Files are written whole or not at all; the PNG encoder round-trips."""

import numpy as np
import pytest

from game.app import outputs
from tests.helpers import decode_png


def test_png_round_trip(tmp_path):
    image = np.random.default_rng(0).integers(0, 255, (7, 5, 3), dtype=np.uint8)
    outputs.write_png(tmp_path / "a.png", image)
    assert np.array_equal(decode_png((tmp_path / "a.png").read_bytes()), image)


def test_interrupted_write_keeps_the_old_file_and_leaves_no_temp(tmp_path):
    target = tmp_path / "stats.json"
    target.write_text("old")

    def boom(f):
        f.write(b"partial")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        outputs.write_with(target, boom)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["stats.json"]
