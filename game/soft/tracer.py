"""The soft-shadow compute pass: visibility of the linear light for every G-buffer pixel.

:class:`SoftTracer` owns every GL object of the pass (its programs, one per method, and its
buffers), creates them explicitly and releases them in :meth:`SoftTracer.release`; its owner (the
:class:`~game.render.traced_lighting.TracedLighting`) releases it. The grid comes from
game/soft/grid.py: the statics' lists are uploaded once, the characters' triangles and lists every
frame.

The methods (game/soft/methods.py) all live in shaders/trace.comp, picked by ``#define METHOD``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from game.gpu import blocks, context, glsl, resources
from game.gpu.blocks import TRACE_DTYPE, TRACE_RESULT_DTYPE
from game.gpu.timing import PassTimer
from game.reference.hard import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE
from game.scene import Scene
from game.scene.geometry import PackedGeometry
from game.soft.grid import BIN_PAD_CELLS, CELLS_PER_TRIANGLE, SceneGrid
from game.soft.methods import METHODS, TraceSettings

COUNTERS = ("ray_triangle_tests", "triangle_triangle_tests", "voxels_visited", "candidates",
            "overflows")
LOCAL_SIZE = 8            # invocations per side of a workgroup; keep in sync with trace.comp
RAY_ID_LIMIT = 1 << 31    # tri-cache ids use 31 bits of the state word
POINTS_PER_ROW = 1024      # trace_points: G-buffer width
# Mesa llvmpipe stops all loops of a shader invocation after 65535 iterations in all (measured
# on Mesa 22.3.6; see loop_budget_left in shaders/trace.comp). Dispatches aim below this.
LOOP_BUDGET = 60_000
LOOP_PROBE_TRIPS = 2
TEXTURE_UNITS = {"u_position": blocks.TEXTURE_UNITS["trace_position"],
                 "u_normal": blocks.TEXTURE_UNITS["trace_normal"],
                 "u_colour": blocks.TEXTURE_UNITS["trace_colour"]}


@dataclass
class TraceResult:
    """What one trace produced; images have row 0 at the top."""

    visibility: np.ndarray            # (H, W) float32, NaN where no geometry
    counters: dict[str, np.ndarray]   # per counter (H, W) uint32
    ms: dict[str, float] = field(default_factory=dict)
    truncated: int = 0                # points whose work llvmpipe's loop budget cut short
    samples_per_dispatch: int = 0

    @property
    def covered(self) -> np.ndarray:
        return np.isfinite(self.visibility)

    def means(self) -> dict[str, float]:
        """Mean of every counter per shaded point."""
        n = int(self.covered.sum())
        return {k: (float(v[self.covered].sum()) / n if n else 0.0)
                for k, v in self.counters.items()}


class SoftTracer:
    """Owns the compute programs and buffers of the soft-shadow pass for one scene."""

    def __init__(self, ctx, geom: PackedGeometry, scene: Scene,
                 cells_per_triangle: float = CELLS_PER_TRIANGLE, clock: str = "auto"):
        self.ctx = ctx
        self.geom = geom
        self.grid = SceneGrid(geom, scene, cells_per_triangle)
        self.timer = PassTimer(ctx, clock)
        self._programs: dict[tuple, object] = {}
        self._pending_static_ms = self.grid.static_ms
        start = time.perf_counter()
        n_static = self.grid.n_static
        self.n_triangles = n_static + self.grid.n_character_tris
        tris = np.zeros((max(1, self.n_triangles), 3, 4), np.float32)
        tris[:n_static, :, :3] = self.grid.static_tris
        self._tris = tris
        self.tri_ssbo = ctx.buffer(tris.tobytes())
        self.static_ssbo = ctx.buffer(self.grid.static.gpu_array().tobytes())
        self.dynamic_ssbo = ctx.buffer(reserve=4 * (self.grid.spec.n_cells + 2))
        self.state_ssbo = ctx.buffer(reserve=4 * max(1, self.n_triangles))
        self.state_ssbo.clear()
        self.params_ubo = ctx.buffer(reserve=TRACE_DTYPE.itemsize)
        self.results_ssbo = ctx.buffer(reserve=TRACE_RESULT_DTYPE.itemsize)
        self._pending_static_ms += (time.perf_counter() - start) * 1e3
        self._ray_id_base = 1
        self._chunks: dict[tuple, int] = {}  # samples per dispatch that last worked

    # -- ownership -------------------------------------------------------------------------------
    def _buffers(self) -> list:
        return [self.tri_ssbo, self.static_ssbo, self.dynamic_ssbo, self.state_ssbo,
                self.params_ubo, self.results_ssbo]

    def gl_objects(self) -> int:
        """GL objects this tracer holds now: buffers, programs, their shader objects (moderngl
        keeps them attached until the program is released) and timer queries."""
        return (len(self._buffers()) + len(self._programs)
                + resources.attached_shaders(self._programs.values()) + self.timer.gl_objects())

    def release(self) -> None:
        for obj in [*self._programs.values(), *self._buffers()]:
            obj.release()
        self._programs = {}
        self.timer.release()

    def memory_bytes(self) -> dict[str, int]:
        """GPU memory of the pass's buffers, by buffer."""
        return {"triangles": self.tri_ssbo.size, "static_cells": self.static_ssbo.size,
                "dynamic_cells": self.dynamic_ssbo.size, "tri_state": self.state_ssbo.size,
                "results": self.results_ssbo.size}

    def _program(self, settings: TraceSettings):
        key = (settings.method, settings.vc_slots, settings.vc_pool, settings.mailbox,
               settings.max_intervals)
        prog = self._programs.get(key)
        if prog is None:
            defines = {f"METHOD_{name.upper().replace('-', '_')}": method.shader_id
                       for name, method in METHODS.items()}
            defines.update(
                METHOD=METHODS[settings.method].shader_id, MAILBOX_SIZE=settings.mailbox,
                VC_SLOTS=settings.vc_slots, VC_POOL=settings.vc_pool,
                MAX_INTERVALS=settings.max_intervals, BIN_PAD_CELLS=BIN_PAD_CELLS,
                TRACE_LIGHT_SEGMENT=blocks.TRACE_LIGHT_SEGMENT,
                TRACE_LIGHT_POINT=blocks.TRACE_LIGHT_POINT,
                TRACE_LIGHT_DIRECTIONAL=blocks.TRACE_LIGHT_DIRECTIONAL)
            prog = self.ctx.compute_shader(glsl.build("trace.comp", defines))
            self._programs[key] = prog
        return prog

    def trace_points(self, points: np.ndarray, normals: np.ndarray, models: np.ndarray,
                     settings: TraceSettings, light) -> TraceResult:
        """Trace chosen points (P, 3) with unit normals (P, 3) instead of a G-buffer.

        For tests and measurements: the points become a G-buffer made here (rows of
        ``POINTS_PER_ROW``) and released before returning. The result's arrays are (P,).
        """
        n = len(points)
        w = min(max(n, 1), POINTS_PER_ROW)
        h = (n + w - 1) // w
        pos = np.zeros((h * w, 4), np.float32)
        nrm = np.zeros((h * w, 4), np.float32)
        covered = np.zeros((h * w, 4), np.uint8)
        pos[:n, :3] = points
        nrm[:n, :3] = normals
        covered[:n, 3] = 255
        textures = [self.ctx.texture((w, h), 4, pos.tobytes(), dtype="f4"),
                    self.ctx.texture((w, h), 4, nrm.tobytes(), dtype="f4"),
                    self.ctx.texture((w, h), 4, covered.tobytes())]
        try:
            result = self.trace(textures, (w, h), models, settings, light)
        finally:
            for tex in textures:
                tex.release()
        # trace() returns images with row 0 at the top; the texture's row 0 is our point 0.
        result.visibility = result.visibility[::-1].reshape(-1)[:n]
        result.counters = {k: v[::-1].reshape(-1)[:n] for k, v in result.counters.items()}
        return result

    # -- the pass --------------------------------------------------------------------------------
    def _upload_characters(self, models: np.ndarray) -> float:
        """Pose the characters, re-bin them and upload; returns the build ms (CPU)."""
        n_static = self.grid.n_static
        start = time.perf_counter()
        tris, lists, _ = self.grid.characters(models)
        if len(tris):
            self._tris[n_static:n_static + len(tris), :, :3] = tris
            self.tri_ssbo.write(self._tris[n_static:].tobytes(), offset=n_static * 48)
        data = lists.gpu_array()
        if self.dynamic_ssbo.size < data.nbytes:
            self.dynamic_ssbo.orphan(data.nbytes)
        self.dynamic_ssbo.write(data.tobytes())
        return (time.perf_counter() - start) * 1e3

    def _params(self, size: tuple[int, int], mode: int, a, b, samples: int,
                first: int = 0, count: int | None = None) -> np.ndarray:
        spec = self.grid.spec
        p = np.zeros(1, TRACE_DTYPE)
        p["grid_origin"], p["grid_cell"], p["grid_dims"] = spec.origin, spec.cell, spec.dims
        p["light_a"], p["light_b"], p["light_mode"] = a, b, mode
        # Rays start off the receiver by the reference's own rule (a share of the scene's
        # diagonal plus a share of the distance from the origin), so both see the same receivers.
        p["ray_offset"] = RAY_OFFSET_SCENE * spec.diagonal
        p["ray_offset_per_metre"] = RAY_OFFSET_DISTANCE
        p["directional_far"] = 4.0 * (spec.diagonal + float(np.linalg.norm(spec.origin)))
        p["samples"], p["triangles"] = samples, self.n_triangles
        p["ray_id_base"] = self._ray_id_base
        p["width"], p["height"] = size
        p["first_sample"] = first
        p["sample_count"] = samples if count is None else count
        p["accumulate"] = int(first > 0)
        p["loop_probe_trips"] = LOOP_PROBE_TRIPS
        return p

    def _first_chunk(self, settings: TraceSettings) -> int:
        """Samples per dispatch to try first: all of them, except for brute force, whose
        iterations per sample (a quarter of the triangles) are known in advance."""
        if settings.method == "brute":
            per_sample = self.n_triangles // 4 + 8
            return max(1, min(settings.samples, LOOP_BUDGET // per_sample))
        return settings.samples

    def _dispatch_all(self, prog, size, mode, a, b, settings: TraceSettings,
                      chunk: int) -> None:
        w, h = size
        n = settings.samples
        exact = not METHODS[settings.method].sampled and mode == blocks.TRACE_LIGHT_SEGMENT
        starts = [0] if exact else range(0, n, chunk)
        for first in starts:
            count = n if exact else min(chunk, n - first)
            self.params_ubo.write(self._params(size, mode, a, b, n, first, count).tobytes())
            prog.run((w + LOCAL_SIZE - 1) // LOCAL_SIZE, (h + LOCAL_SIZE - 1) // LOCAL_SIZE)
            # The next dispatch adds to these results: make the writes visible to it.
            self.ctx.memory_barrier()
        context.unbind_program()

    def trace(self, textures, size: tuple[int, int], models: np.ndarray,
              settings: TraceSettings, light: tuple[int, np.ndarray, np.ndarray]) -> TraceResult:
        """Run the pass over a G-buffer.

        Parameters
        ----------
        textures
            (position, normal, colour) textures of the frame's G-buffer (game/render/target.py).
        models
            The characters' (4, 4) model matrices of the frame.
        light
            (mode, a, b): ``TRACE_LIGHT_SEGMENT`` with the segment's ends, ``TRACE_LIGHT_POINT``
            with the position in ``a``, or ``TRACE_LIGHT_DIRECTIONAL`` with the unit direction
            toward the light in ``a``.
        """
        timer = self.timer
        w, h = size
        timer.begin_frame()
        prog = self._program(settings)
        mode, a, b = light
        with timer.measure("total", wall=True):
            with timer.measure("build", wall=True):
                build_ms = self._pending_static_ms
                self._pending_static_ms = 0.0
                dynamic_ms = self._upload_characters(models)
                need = TRACE_RESULT_DTYPE.itemsize * w * h
                if self.results_ssbo.size != need:
                    self.results_ssbo.orphan(need)
                if self._ray_id_base + 2 * w * h >= RAY_ID_LIMIT:
                    self.state_ssbo.clear()
                    self._ray_id_base = 1
                self._ray_id_base += w * h
            self.params_ubo.bind_to_uniform_block(blocks.BINDINGS["TraceParams"])
            for buf, name in ((self.tri_ssbo, "Triangles"), (self.static_ssbo, "StaticCells"),
                              (self.dynamic_ssbo, "DynamicCells"), (self.state_ssbo, "TriState"),
                              (self.results_ssbo, "Results")):
                buf.bind_to_storage_buffer(blocks.BINDINGS[name])
            for tex, (name, unit) in zip(textures, TEXTURE_UNITS.items(), strict=True):
                tex.use(unit)
                try:
                    prog[name].value = unit
                except KeyError:  # the method does not read it; the compiler dropped it
                    pass
            # llvmpipe's loop budget (shaders/trace.comp loop_budget_left): halve the samples
            # per dispatch until no point runs out; the discarded attempts are timed apart.
            key = (settings.method, settings.samples, settings.vc_slots, settings.vc_pool)
            chunk = self._chunks.get(key) or self._first_chunk(settings)
            discarded = 0.0
            while True:
                timer.ms.pop("trace", None)
                with timer.measure("trace"):
                    self._dispatch_all(prog, size, mode, a, b, settings, chunk)
                results = np.frombuffer(self.results_ssbo.read(), TRACE_RESULT_DTYPE)
                if not results["truncated"].any() or chunk == 1:
                    break
                discarded += timer.ms["trace"]
                chunk = (chunk + 1) // 2
            # Later frames start from the split that worked (frames change little).
            self._chunks[key] = chunk
        raw = results.reshape(h, w)[::-1]  # the last attempt's read, used for everything
        vis = raw["visibility"].astype(np.float32)
        vis = np.where(vis < 0.0, np.nan, vis).astype(np.float32)
        ms = dict(timer.ms)
        ms["build_static"] = build_ms
        ms["build_dynamic"] = dynamic_ms
        # The static part's CPU build ran in __init__, before this frame: count it here once.
        ms["build"] = ms.get("build", 0.0) + build_ms
        ms["total"] = ms.get("total", 0.0) + build_ms
        ms["trace_discarded"] = discarded
        counters = {name: np.ascontiguousarray(raw[name]) for name in COUNTERS}
        sampled = METHODS[settings.method].sampled
        return TraceResult(visibility=vis, counters=counters, ms=ms,
                           truncated=int(raw["truncated"][np.isfinite(vis)].sum()),
                           samples_per_dispatch=chunk if sampled else settings.samples)
