"""Constants and small helpers the test modules share: the paths of the test scenes, the image
sizes and the accuracy bound, and a PNG decoder. Not a test module; fixtures live in
tests/conftest.py."""

from __future__ import annotations

import signal
import struct
import zlib
from pathlib import Path

import numpy as np

from game.scene import default_scene_path, reference_scene_path

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "tests" / "scenes"
ASSETS = ROOT / "assets"
DEFAULT = default_scene_path()        # the built-in town square
COURTYARD = reference_scene_path()     # the reference scene of the benchmark and most tests
TINY = SCENES / "tiny.toml"
POINT = SCENES / "point.toml"
SPOT = SCENES / "spot.toml"
LOW_SUN = SCENES / "low_sun.toml"
POINT_AMONG = SCENES / "point_among.toml"
SPOT_SLAB = SCENES / "spot_slab.toml"  # a spot lamp over a slab that reaches behind it
PLAZA = SCENES / "plaza_128.toml"      # 128 capsule walkers, three boxes, a sun

ACCURACY_SIZE = (320, 180)   # frames scored against Embree
SMALL_SIZE = (160, 90)       # frames compared with each other
MAX_ERROR = 0.05             # the shadow-error bound every method holds on ACCURACY_SCENES
# The scenes the accuracy bound is asserted on, for every method.
ACCURACY_SCENES = {"courtyard": COURTYARD, "square": DEFAULT, "spot": SPOT, "point": POINT,
                   "low_sun": LOW_SUN, "point_among": POINT_AMONG, "spot_slab": SPOT_SLAB}


def stoppable() -> None:
    """``preexec_fn`` for a child that a test stops with a signal: SIGINT, SIGTERM and SIGHUP at
    their defaults, as in a foreground run. A test run started in the background (``pytest &``)
    passes SIGINT on ignored, and the program rightly keeps ignoring it."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def decode_png(data: bytes) -> np.ndarray:
    """Decode the PNGs game/app/outputs.py writes (8-bit RGB, filter 0 on every row)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, size = 8, b"", None
    while pos < len(data):
        length = struct.unpack(">I", data[pos:pos + 4])[0]
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            size = struct.unpack(">II", body[:8])
            assert body[8:10] == bytes([8, 2]), "expected 8-bit RGB"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    w, h = size
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + 3 * w)
    assert not rows[:, 0].any(), "expected filter 0 on every row"
    return rows[:, 1:].reshape(h, w, 3)


def read_png(path: Path) -> np.ndarray:
    """The PNG file ``path`` (as game/app/outputs.py writes them) as an (H, W, 3) array."""
    return decode_png(path.read_bytes())
