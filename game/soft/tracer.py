"""The soft-shadow compute pass: visibility of the linear light for every G-buffer pixel.

:class:`SoftTracer` owns every GL object of the pass (its programs, one per method, and its
buffers), creates them explicitly and releases them in :meth:`SoftTracer.release`; its owner (the
:class:`~game.render.traced_lighting.TracedLighting`) releases it. The grid comes from
game/soft/grid.py: the statics' lists are uploaded once, the characters' triangles and lists every
frame.

The methods (game/soft/methods.py) all live in shaders/trace.comp and the trace_*.glsl files it
includes, picked by ``#define METHOD``.
What a trace returns is decoded by game/soft/results.py.
"""

from __future__ import annotations

import time

import numpy as np

from game.gpu import blocks, context, glsl, resources
from game.gpu.blocks import TRACE_DTYPE, TRACE_RESULT_DTYPE
from game.gpu.timing import PassTimer
from game.reference.hard import RAY_OFFSET_DISTANCE, RAY_OFFSET_SCENE
from game.scene import Scene
from game.scene.geometry import PackedGeometry
from game.soft.grid import (
    BIN_PAD_CELLS,
    CELLS_PER_TRIANGLE,
    DEFAULT_STRUCTURE,
    SUB_DIMS_BITS,
    SceneGrid,
)
from game.soft.methods import TRACED_METHODS, TraceSettings
from game.soft.results import TraceResult, decode_results

TRIANGLE_BYTES = 48       # three vec4 per triangle in the Triangles buffer
LOCAL_SIZE = 8            # invocations per side of a workgroup; keep in sync with trace.comp
SCATTER_GROUP = 64        # invocations per workgroup of scatter.comp; keep in sync with it
# Room for the characters' ids and scatter entries, per character triangle, before a frame needs
# more (a small triangle touches one or two leaves: an id, and an entry of three ints per leaf).
DYNAMIC_INTS_PER_TRIANGLE = 8
RAY_ID_LIMIT = 1 << 31    # tri-cache ids use 31 bits of the state word
POINTS_PER_ROW = 1024      # trace_points: G-buffer width
# Mesa llvmpipe stops all loops of a shader invocation after 65535 iterations in all (measured
# on Mesa 22.3.6; see loop_budget_left in shaders/trace_budget.glsl). It runs eight invocations
# in the lanes of one 256-bit vector, and a loop runs as long as any lane needs it: lanes whose
# loops diverge add up, so eight points of STEP_BUDGET steps each stay below the limit (the steps
# count every loop trip a point makes, and at most a few hundred more run before a point can
# stop). A trace that the probe still finds cut short (wider vectors, say) runs again with half
# the budget, down to MIN_STEP_BUDGET.
STEP_BUDGET = 7_000
MIN_STEP_BUDGET = 500
LOOP_PROBE_TRIPS = 2
# A point makes progress in every dispatch, so this many rounds mean a fault in the shader.
MAX_ROUNDS = 1 << 20
# voxel-cache: a leaf longer than this is walked as the grid method walks it (an overflow), so
# that building one leaf's candidates, which is not split (two steps per entry), stays within
# one point's STEP_BUDGET.
VC_BIG_LEAF = 2048
# analytic: hidden intervals a point keeps between dispatches (PointResult.kept_intervals).
ANALYTIC_KEPT = 8
TEXTURE_UNITS = {"u_position": blocks.TEXTURE_UNITS["trace_position"],
                 "u_normal": blocks.TEXTURE_UNITS["trace_normal"],
                 "u_colour": blocks.TEXTURE_UNITS["trace_colour"]}


class SoftTracer:
    """Owns the compute programs and buffers of the soft-shadow pass for one scene."""

    def __init__(self, ctx, geom: PackedGeometry, scene: Scene,
                 cells_per_triangle: float = CELLS_PER_TRIANGLE, clock: str = "auto",
                 structure: str = DEFAULT_STRUCTURE):
        self.ctx = ctx
        self.geom = geom
        self.scene = scene
        self.cells_per_triangle = cells_per_triangle
        self.timer = PassTimer(ctx, clock)
        self._programs: dict[tuple, object] = {}
        self._grids: dict[str, SceneGrid] = {}
        self._static: dict[str, np.ndarray] = {}
        self._pending_static_ms = 0.0
        self.grid = self._grid(structure)
        start = time.perf_counter()
        n_static = self.grid.n_static
        self.n_triangles = n_static + self.grid.n_character_tris
        tris = np.zeros((max(1, self.n_triangles), 3, 4), np.float32)
        tris[:n_static, :, :3] = self.grid.static_tris
        self._tris = tris
        self.tri_ssbo = ctx.buffer(tris.tobytes())
        self.static_ssbo = ctx.buffer(self._static[structure].tobytes())
        self.dynamic_ssbo = ctx.buffer(reserve=4)
        self._dynamic_leaves = np.zeros(0, np.int64)  # leaves whose pairs are set
        self._posed: np.ndarray | None = None  # the model matrices last uploaded
        self._reset_dynamic(DYNAMIC_INTS_PER_TRIANGLE * self.grid.n_character_tris)
        self.scatter_prog = ctx.compute_shader(glsl.build("scatter.comp"))
        self.state_ssbo = ctx.buffer(reserve=4 * max(1, self.n_triangles))
        self.state_ssbo.clear()
        self.params_ubo = ctx.buffer(reserve=TRACE_DTYPE.itemsize)
        self.results_ssbo = ctx.buffer(reserve=TRACE_RESULT_DTYPE.itemsize)
        self._pending_static_ms += (time.perf_counter() - start) * 1e3
        self._ray_id_base = 1
        self._budgets: dict[tuple, int] = {}  # the step budget that last worked

    def _grid(self, structure: str) -> SceneGrid:
        """The scene's structure of that kind, built (on the CPU) the first time it is asked
        for; its build time is reported by the next trace."""
        grid = self._grids.get(structure)
        if grid is None:
            grid = SceneGrid(self.geom, self.scene, self.cells_per_triangle, structure)
            start = time.perf_counter()
            self._static[structure] = grid.structure.gpu_array(grid.static)
            self._pending_static_ms += grid.static_ms + (time.perf_counter() - start) * 1e3
            self._grids[structure] = grid
        return grid

    def _use_structure(self, structure: str) -> None:
        """Make ``structure`` the one the pass reads (its static part uploaded)."""
        if structure == self.grid.kind:
            return
        self.grid = self._grid(structure)
        start = time.perf_counter()
        array = self._static[structure]
        if self.static_ssbo.size != array.nbytes:
            self.static_ssbo.orphan(array.nbytes)
        self.static_ssbo.write(array.tobytes())
        self._reset_dynamic(DYNAMIC_INTS_PER_TRIANGLE * self.grid.n_character_tris)
        self._pending_static_ms += (time.perf_counter() - start) * 1e3

    # -- ownership -------------------------------------------------------------------------------
    def _buffers(self) -> list:
        return [self.tri_ssbo, self.static_ssbo, self.dynamic_ssbo, self.state_ssbo,
                self.params_ubo, self.results_ssbo]

    def _all_programs(self) -> list:
        return [*self._programs.values(), self.scatter_prog]

    def gl_objects(self) -> int:
        """GL objects this tracer holds now: buffers, programs, their shader objects (moderngl
        keeps them attached until the program is released) and timer queries."""
        programs = self._all_programs()
        return (len(self._buffers()) + len(programs)
                + resources.attached_shaders(programs) + self.timer.gl_objects())

    def release(self) -> None:
        for obj in [*self._all_programs(), *self._buffers()]:
            obj.release()
        self._programs = {}
        self.timer.release()

    def memory_bytes(self) -> dict[str, int]:
        """GPU memory of the pass's buffers, by buffer (the structure in use)."""
        return {"triangles": self.tri_ssbo.size, "static_cells": self.static_ssbo.size,
                "dynamic_cells": self.dynamic_ssbo.size, "tri_state": self.state_ssbo.size,
                "results": self.results_ssbo.size}

    def _program(self, settings: TraceSettings):
        key = (settings.method, settings.structure, settings.vc_slots, settings.vc_pool,
               settings.mailbox, settings.max_intervals)
        prog = self._programs.get(key)
        if prog is None:
            prog = self.ctx.compute_shader(glsl.build("trace.comp", _defines(settings)))
            self._programs[key] = prog
        return prog

    def trace_points(self, points: np.ndarray, normals: np.ndarray, models: np.ndarray,
                     settings: TraceSettings, light) -> TraceResult:
        """Trace chosen points (P, 3) with unit normals (P, 3) instead of a G-buffer.

        For tests and measurements: the points become a G-buffer made here (rows of
        ``POINTS_PER_ROW``) and released before returning. The result's arrays are (P,).
        """
        n = len(points)
        textures, (w, h) = _points_gbuffer(self.ctx, points, normals)
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
    def _reset_dynamic(self, ints: int) -> None:
        """Room for the structure's leaf pairs and ``ints`` more (ids and scatter entries), every
        pair cleared."""
        need = 4 * (2 * self.grid.structure.n_leaves + max(ints, 1))
        if self.dynamic_ssbo.size < need:
            self.dynamic_ssbo.orphan(need)
        self.dynamic_ssbo.clear()
        self._dynamic_leaves = np.zeros(0, np.int64)
        self._posed = None

    def _upload_characters(self, models: np.ndarray) -> float:
        """Pose the characters, bin them into the structure's leaves and upload; returns the
        build ms (CPU). Poses already uploaded (a still frame traced again, the bands of one
        frame) cost nothing."""
        if self._posed is not None and np.array_equal(self._posed, models):
            return 0.0
        n_static = self.grid.n_static
        start = time.perf_counter()
        tris, lists, _ = self.grid.characters(models)
        if len(tris):
            self._tris[n_static:n_static + len(tris), :, :3] = tris
            self.tri_ssbo.write(self._tris[n_static:].tobytes(), offset=n_static * 48)
        # The ids after the leaf pairs, then the scatter entries: the pairs of this frame's
        # leaves, and empty pairs for the leaves the characters left.
        base = 2 * self.grid.structure.n_leaves
        left = np.setdiff1d(self._dynamic_leaves, lists.leaves, assume_unique=True)
        entries = np.zeros((len(lists.leaves) + len(left), 3), np.int64)
        entries[:len(lists.leaves)] = np.stack(
            [lists.leaves, base + lists.starts, lists.counts], axis=1)
        entries[len(lists.leaves):, 0] = left
        tail = np.concatenate([lists.ids, entries.ravel()]).astype(np.int32)
        if self.dynamic_ssbo.size < 4 * (base + len(tail)):
            self._reset_dynamic(2 * len(tail))
        self.dynamic_ssbo.write(tail.tobytes(), offset=4 * base)
        if len(entries):
            self.dynamic_ssbo.bind_to_storage_buffer(blocks.BINDINGS["DynamicCells"])
            self.scatter_prog["u_first"].value = base + len(lists.ids)
            self.scatter_prog["u_count"].value = len(entries)
            self.scatter_prog.run((len(entries) + SCATTER_GROUP - 1) // SCATTER_GROUP)
            self.ctx.memory_barrier()
        self._dynamic_leaves = lists.leaves
        self._posed = np.array(models, copy=True)
        return (time.perf_counter() - start) * 1e3

    def _params(self, size: tuple[int, int], mode: int, a, b, samples: int,
                round_index: int = 0, budget: int = STEP_BUDGET) -> np.ndarray:
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
        p["round_index"] = round_index
        p["step_budget"] = budget
        p["loop_probe_trips"] = LOOP_PROBE_TRIPS
        return p

    def _rounds(self, prog, size, mode, a, b, settings: TraceSettings,
                budget: int) -> tuple[int, bool]:
        """Dispatch until no point has work left; returns the rounds and whether any point was
        cut short (its results are then incomplete). Above MIN_STEP_BUDGET the first cut ends
        the attempt, which runs again with a smaller budget."""
        cut = False
        w, h = size
        item = TRACE_RESULT_DTYPE.itemsize
        totals = w * h * item  # the record after the points
        zero = np.zeros(1, TRACE_RESULT_DTYPE).tobytes()
        for r in range(MAX_ROUNDS):
            self.results_ssbo.write(zero, offset=totals)
            self.params_ubo.write(self._params(size, mode, a, b, settings.samples, r,
                                               budget).tobytes())
            prog.run((w + LOCAL_SIZE - 1) // LOCAL_SIZE, (h + LOCAL_SIZE - 1) // LOCAL_SIZE)
            # The next round reads these results, and so does the CPU.
            self.ctx.memory_barrier()
            summary = np.frombuffer(self.results_ssbo.read(size=item, offset=totals),
                                    TRACE_RESULT_DTYPE)[0]
            cut = cut or bool(summary["truncated"])
            if cut and budget > MIN_STEP_BUDGET:
                return r + 1, True
            if summary["pending"] == 0:
                return r + 1, cut
        raise RuntimeError(f"the soft-shadow trace did not finish in {MAX_ROUNDS} dispatches")

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
        with timer.measure("total", wall=True):
            with timer.measure("build", wall=True):
                build_ms, dynamic_ms = self._prepare(size, models, settings)
            self._bind(prog, textures)
            rounds, budget, discarded = self._dispatch(prog, size, light, settings)
            context.unbind_program()
            results = np.frombuffer(
                self.results_ssbo.read(size=TRACE_RESULT_DTYPE.itemsize * w * h),
                TRACE_RESULT_DTYPE)
        ms = dict(timer.ms)
        ms["build_static"] = build_ms
        ms["build_dynamic"] = dynamic_ms
        # The static part's CPU build ran before this frame: count it here once.
        ms["build"] = ms.get("build", 0.0) + build_ms
        ms["total"] = ms.get("total", 0.0) + build_ms
        ms["trace_discarded"] = discarded
        return decode_results(results.reshape(h, w)[::-1], settings, light[0], ms, rounds, budget)

    def _prepare(self, size: tuple[int, int], models: np.ndarray,
                 settings: TraceSettings) -> tuple[float, float]:
        """The structure, the characters and the results buffer made ready for a trace of
        ``size``; returns the static build ms not yet reported and the characters' build ms."""
        w, h = size
        self._use_structure(settings.structure)
        build_ms = self._pending_static_ms
        self._pending_static_ms = 0.0
        dynamic_ms = self._upload_characters(models)
        need = TRACE_RESULT_DTYPE.itemsize * (w * h + 1)
        if self.results_ssbo.size != need:
            self.results_ssbo.orphan(need)
        if self._ray_id_base + 2 * w * h >= RAY_ID_LIMIT:
            self.state_ssbo.clear()
            self._ray_id_base = 1
        self._ray_id_base += w * h
        return build_ms, dynamic_ms

    def _bind(self, prog, textures) -> None:
        """Bind the pass's buffers and the G-buffer's textures for ``prog``."""
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

    def _dispatch(self, prog, size: tuple[int, int], light,
                  settings: TraceSettings) -> tuple[int, int, float]:
        """Rounds of dispatches, each point resuming where its step budget ran out (llvmpipe's
        loop budget, shaders/trace_budget.glsl loop_budget_left); a trace that still cut a point
        short runs again with half the budget, timed apart. Returns the rounds, the budget that
        worked and the ms of the attempts thrown away."""
        timer = self.timer
        mode, a, b = light
        key = (settings.method, settings.structure, settings.samples, settings.vc_slots,
               settings.vc_pool, settings.max_intervals)
        budget = self._budgets.get(key, STEP_BUDGET)
        discarded = 0.0
        while True:
            timer.ms.pop("trace", None)
            with timer.measure("trace"):
                rounds, cut = self._rounds(prog, size, mode, a, b, settings, budget)
            if not cut or budget <= MIN_STEP_BUDGET:
                break
            discarded += timer.ms["trace"]
            budget = max(MIN_STEP_BUDGET, budget // 2)
        # Later frames start from the budget that worked (frames change little).
        self._budgets[key] = budget
        return rounds, budget, discarded


def _points_gbuffer(ctx, points: np.ndarray, normals: np.ndarray) -> tuple[list, tuple[int, int]]:
    """A G-buffer of the points (P, 3) and unit normals (P, 3), ``POINTS_PER_ROW`` to a row: its
    (position, normal, colour) textures, which the caller releases, and its size."""
    n = len(points)
    w = min(max(n, 1), POINTS_PER_ROW)
    h = (n + w - 1) // w
    pos = np.zeros((h * w, 4), np.float32)
    nrm = np.zeros((h * w, 4), np.float32)
    covered = np.zeros((h * w, 4), np.uint8)
    pos[:n, :3] = points
    nrm[:n, :3] = normals
    covered[:n, 3] = 255
    textures = [ctx.texture((w, h), 4, pos.tobytes(), dtype="f4"),
                ctx.texture((w, h), 4, nrm.tobytes(), dtype="f4"),
                ctx.texture((w, h), 4, covered.tobytes())]
    return textures, (w, h)


def _defines(settings: TraceSettings) -> dict:
    """The ``#define``s of trace.comp for ``settings``: the method, its sizes and the constants
    the shader shares with this module."""
    defines = {f"METHOD_{name.upper().replace('-', '_')}": method.shader_id
               for name, method in TRACED_METHODS.items()}
    defines.update(
        METHOD=TRACED_METHODS[settings.method].shader_id, MAILBOX_SIZE=settings.mailbox,
        VC_SLOTS=settings.vc_slots, VC_POOL=settings.vc_pool,
        MAX_INTERVALS=settings.max_intervals, BIN_PAD_CELLS=BIN_PAD_CELLS,
        TRIANGLE_BYTES=TRIANGLE_BYTES, VC_BIG_LEAF=VC_BIG_LEAF,
        ANALYTIC_KEPT=ANALYTIC_KEPT, TWO_LEVEL=settings.structure != "uniform",
        SUB_DIMS_BITS=SUB_DIMS_BITS,
        TRACE_LIGHT_SEGMENT=blocks.TRACE_LIGHT_SEGMENT,
        TRACE_LIGHT_POINT=blocks.TRACE_LIGHT_POINT,
        TRACE_LIGHT_DIRECTIONAL=blocks.TRACE_LIGHT_DIRECTIONAL)
    return defines
