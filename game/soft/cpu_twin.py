"""A CPU twin of the soft-shadow tracer's sampled methods (``brute``, ``grid``, ``tri-cache``,
``voxel-cache``), compiled by numba, to measure on a CPU what the GPU pass cannot show: native
milliseconds and, under a cache simulator, the cache misses of each method's memory accesses.

It reads the very arrays the GPU pass reads, from the tracer's own buffers after a trace (the
``Triangles`` buffer of three ``vec4`` per triangle, the static leaf pairs and lists of
:meth:`~game.soft.grid.Structure.gpu_array`, the characters' pairs and lists after
``scatter.comp``), traces the same G-buffer points with the same samples
(:func:`game.reference.soft.tracer_samples`), and counts what the shader counts (ray-triangle
tests, triangle-triangle tests, voxels visited, candidates, overflows and bytes read by kind).
The kernels (game/soft/twin_kernel.py, game/soft/twin_walk.py) follow shaders/trace.comp in
float32, operation by operation.

What differs from the GPU pass: a point is never split into dispatches (llvmpipe's loop budget
is no concern here), so its voxel cache lives for all its samples; on the GPU a split point
starts each dispatch with an empty cache and counts more triangle-triangle tests. Visibility is
the same either way. In the multi-threaded run, ``tri-cache``'s per-triangle words are shared by
the threads as they are by GPU invocations: a word another thread overwrote costs a repeated
test, never a wrong answer.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from game.errors import GameError
from game.reference.hard import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE
from game.reference.soft import tracer_samples
from game.soft.methods import SAMPLED_METHODS, TraceSettings

NUMBA_HINT = ("the CPU twin needs numba: pip install -e '.[cache]' (or pip install numba)")
# Points per chunk: the threads of a multi-threaded run take every n-th chunk, which spreads
# the image's costly rows over them.
CHUNK = 16
VC_BIG_LEAF = 2048  # as game/soft/tracer.py: a longer leaf is walked whole by voxel-cache
METHOD_IDS = {"brute": 0, "grid": 1, "tri-cache": 2, "voxel-cache": 3}
assert set(METHOD_IDS) == set(SAMPLED_METHODS)


def numba_available() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def kernels():
    """The compiled kernels module (game/soft/twin_walk.py); GameError without numba."""
    if not numba_available():
        raise GameError(NUMBA_HINT)
    from game.soft import twin_walk
    return twin_walk


@dataclass
class TwinScene:
    """The arrays the GPU pass reads, and its parameters, as float32 and int32."""

    tris: np.ndarray       # (T * 12,) float32: three vec4 per triangle
    static: np.ndarray     # int32: leaf pairs, then ids (Structure.gpu_array)
    dynamic: np.ndarray    # int32: the characters' leaf pairs, then their ids
    n_triangles: int
    origin: np.ndarray     # (3,) float32, the top grid
    cell: np.ndarray       # (3,) float32
    dims: np.ndarray       # (3,) int64
    a: np.ndarray          # (3,) float32, the segment light
    b: np.ndarray
    ray_offset: np.float32
    ray_offset_per_metre: np.float32
    structure: str

    @classmethod
    def from_tracer(cls, tracer, light) -> TwinScene:
        """What ``tracer`` (a SoftTracer that has just traced) gives the shader for ``light``
        (mode, a, b): read back from its buffers."""
        spec = tracer.grid.spec
        f32 = np.float32
        return cls(tris=np.frombuffer(tracer.tri_ssbo.read(), np.float32).copy(),
                   static=np.frombuffer(tracer.static_ssbo.read(), np.int32).copy(),
                   dynamic=np.frombuffer(tracer.dynamic_ssbo.read(), np.int32).copy(),
                   n_triangles=int(tracer.n_triangles),
                   origin=np.asarray(spec.origin, f32), cell=np.asarray(spec.cell, f32),
                   dims=np.asarray(spec.dims, np.int64),
                   a=np.asarray(light[1], f32), b=np.asarray(light[2], f32),
                   ray_offset=f32(RAY_OFFSET_SCENE * spec.diagonal),
                   ray_offset_per_metre=f32(RAY_OFFSET_DISTANCE), structure=tracer.grid.kind)

    def packed(self) -> tuple:
        """The kernels' scene tuple."""
        t3 = lambda v: tuple(np.float32(x) for x in v)  # noqa: E731
        grid = (t3(self.origin), t3(self.cell), tuple(int(x) for x in self.dims))
        return (self.tris, self.static, self.dynamic, self.n_triangles, grid, t3(self.a),
                t3(self.b), (self.ray_offset, self.ray_offset_per_metre), VC_BIG_LEAF)

    def arrays(self) -> dict[str, np.ndarray]:
        """Everything, as arrays (to hand the scene to another process through an .npz)."""
        return {"tris": self.tris, "static": self.static, "dynamic": self.dynamic,
                "n_triangles": np.array(self.n_triangles), "origin": self.origin,
                "cell": self.cell, "dims": self.dims, "a": self.a, "b": self.b,
                "offsets": np.array([self.ray_offset, self.ray_offset_per_metre], np.float32),
                "structure": np.array(self.structure)}

    @classmethod
    def from_arrays(cls, z) -> TwinScene:
        return cls(tris=z["tris"], static=z["static"], dynamic=z["dynamic"],
                   n_triangles=int(z["n_triangles"]), origin=z["origin"], cell=z["cell"],
                   dims=z["dims"], a=z["a"], b=z["b"], ray_offset=np.float32(z["offsets"][0]),
                   ray_offset_per_metre=np.float32(z["offsets"][1]),
                   structure=str(z["structure"]))

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays every method may read (triangles and the structure)."""
        return self.tris.nbytes + self.static.nbytes + self.dynamic.nbytes


@dataclass
class TwinPoints:
    """Shaded points: G-buffer positions and normals, and each one's pixel index in the GPU
    pass (row 0 at the bottom), which seeds its samples and its tri-cache ray id."""

    positions: np.ndarray  # (P, 3) float32
    normals: np.ndarray    # (P, 3) float32
    index: np.ndarray      # (P,) int64

    @classmethod
    def from_gbuffer(cls, gbuffer: dict) -> tuple[TwinPoints, np.ndarray]:
        """The covered pixels of a frame's G-buffer (row 0 at the top) and the coverage mask."""
        pos = gbuffer["position"]
        covered = np.isfinite(pos).all(axis=-1)
        h, w = covered.shape
        rows, cols = np.nonzero(covered)
        index = (h - 1 - rows).astype(np.int64) * w + cols
        return cls(np.ascontiguousarray(pos[covered], np.float32),
                   np.ascontiguousarray(gbuffer["normal"][covered], np.float32), index), covered

    def __len__(self) -> int:
        return len(self.index)


@dataclass
class TwinResult:
    visible: np.ndarray    # (P,) visible samples
    rays: np.ndarray       # (P,) rays traced (samples above the horizon)
    counters: dict[str, np.ndarray] | None  # per point, when counted
    seconds: float
    samples: int

    @property
    def visibility(self) -> np.ndarray:
        """As the shader writes it: float(visible) / float(samples), in float32."""
        return self.visible.astype(np.float32) / np.float32(self.samples)


def kernel_args(scene: TwinScene, points: TwinPoints, method: str, samples: int,
                count: bool = True, settings: TraceSettings | None = None) -> tuple:
    """The kernels' arguments for one trace; the outputs (visible, rays, counters) are the
    arrays at positions -5, -4 and -3."""
    if method not in METHOD_IDS:
        raise GameError(f"the CPU twin has no method {method!r}; valid: {', '.join(METHOD_IDS)}")
    settings = settings or TraceSettings(method=method, samples=samples)
    t = np.ascontiguousarray(tracer_samples(points.index.astype(np.uint32), samples))
    n = len(points)
    words = np.zeros(max(1, scene.n_triangles), np.uint32)  # tri-cache: every word unused
    sizes = (settings.mailbox, settings.vc_slots, settings.vc_pool)
    # Each chunk of points gets a row of scratch: mailbox and cursor, the voxel cache's keys,
    # starts and counts, its pool and its fill.
    scratch = np.zeros((max(1, -(-n // CHUNK)), settings.mailbox + 2 + 3 * settings.vc_slots
                        + settings.vc_pool), np.int32)
    return (scene.packed(), points.positions, points.normals, points.index, t,
            METHOD_IDS[method], sizes, words, np.zeros(n, np.int64), np.zeros(n, np.int64),
            np.zeros((n, 8), np.int64), count, scratch)


def trace(scene: TwinScene, points: TwinPoints, method: str, samples: int,
          threads: int | None = None, count: bool = True,
          settings: TraceSettings | None = None) -> TwinResult:
    """Trace ``points`` with ``method`` and ``samples`` per point. ``threads`` None: serially
    on this thread; else on that many threads, each taking every ``threads``-th chunk of
    ``CHUNK`` points (the kernels release the GIL). ``count``: keep the shader's counters."""
    k = kernels()
    args = kernel_args(scene, points, method, samples, count, settings)
    if threads is None or threads <= 1:
        start = time.perf_counter()
        k.trace_strided(0, 1, CHUNK, *args)
        seconds = time.perf_counter() - start
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(lambda w: None, range(threads)))  # the threads started, untimed
            start = time.perf_counter()
            list(pool.map(lambda w: k.trace_strided(w, threads, CHUNK, *args), range(threads)))
            seconds = time.perf_counter() - start
    visible, rays, cnt = args[-5:-2]
    counters = None
    if count:
        counters = {name: cnt[:, i].copy() for i, name in enumerate(k.COUNTER_NAMES)}
    return TwinResult(visible, rays, counters, seconds, samples)
