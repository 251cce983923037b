"""The window's raster soft shadows through the shading pass (game/soft/direct.py): before the
pass, the points drawn unlit at one pixel per block, the method's maps and its lookup at them,
and the blocks' values; after it, the composite over the blocks that look the light up, and
what a still view refines.

The frame's total holds what runs before the shading pass; reading back the blocks the shading
pass marked, and the composite, add to it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from game.gpu.timing import PassTimer
from game.render import passes
from game.render.frame import Frame, View
from game.render.target import FrameTarget, GBuffer
from game.soft.composite import SoftComposite
from game.soft.direct import DirectRaster
from game.soft.methods import TraceSettings
from game.soft.raster import RasterSoft
from game.soft.settle import ExactTrace
from game.soft.still_lookups import refine_phase
from game.soft.tracer import TraceResult

UPSAMPLE = "soft_upsample"   # the points, the blocks' values and the marked ones
COMPOSITE = "composite"
REFINE = "soft_refine"       # a still view's maps from other points, and their lookups
SETTLE = "soft_settle"       # a still view's pixels traced exactly (game/soft/settle.py)


class DirectFrames:
    """Owns the blocks (:class:`~game.soft.direct.DirectRaster`) and the points' G-buffer (a
    :class:`FrameTarget` of one pixel per block), released by :meth:`release`."""

    def __init__(self, ctx, timer: PassTimer, divisor: int):
        self.ctx = ctx
        self.timer = timer
        self.blocks = DirectRaster(ctx, divisor)
        self.points: FrameTarget | None = None
        self.result: TraceResult | None = None    # the last frame's trace at the points
        self.settings: TraceSettings | None = None
        self._clip_to_world = np.eye(4)           # and its clip space -> world
        self._models = np.zeros((0, 4, 4))        # the walkers' poses of the frame
        self._draw_points: Callable[[FrameTarget], None] | None = None   # the frame's scene

    @property
    def divisor(self) -> int:
        return self.blocks.divisor

    def before_shade(self, raster: RasterSoft, models: np.ndarray, moved: np.ndarray,
                     settings: TraceSettings, light: tuple, radiance: np.ndarray, view: View,
                     plan_key: bytes | None, draw_points: Callable[[FrameTarget], None]
                     ) -> Callable[[object], None]:
        """The points drawn (``draw_points`` into the points' target), ``raster``'s maps of
        the linear ``light`` and its lookup at them, the blocks' values, with what a still
        view kept where no walker moved (``moved``: their boxes, game/soft/accumulate.py's
        ``walker_boxes``). Returns what binds them to the shading pass's program.
        ``plan_key`` as :meth:`RasterSoft.trace` takes: it names the view."""
        with self.timer.measure(UPSAMPLE):
            cells = self.blocks.resize(view.size)
            if self.points is None:
                self.points = FrameTarget(self.ctx, cells, GBuffer.FULL)
            self.points.remake(cells, GBuffer.FULL)
            self.points.covers = self.blocks.covers
            draw_points(self.points)
        self._draw_points = draw_points
        points = self.points
        self.result = raster.trace((points.position, points.normal, points.colour), cells,
                                   models, settings, light, plan_key=plan_key)
        view_proj = view.proj @ view.view
        with self.timer.measure(UPSAMPLE):
            key = (None if plan_key is None
                   else plan_key + repr(settings).encode() + np.asarray(light[1:]).tobytes())
            kept = self.blocks.still.kept(key, view.size, self.divisor, points, moved, light,
                                          view_proj)
            self.blocks.classify(self.result, kept, settings)
        self.settings = settings
        self._models = models
        self._clip_to_world = np.linalg.inv(view_proj)
        soft_light = (light[1] + light[2]) / 2
        return lambda program: self.blocks.bind_shading(program, soft_light, radiance)

    def composite(self, frame: Frame, composite: SoftComposite, raster: RasterSoft,
                  target: FrameTarget, radiance: np.ndarray, read: bool,
                  exact: ExactTrace | None = None) -> TraceResult:
        """The blocks that look the light up, lit over the picture the shading pass drew into
        ``target``, and a still view's refining round, or once it has refined, its batch of
        pixels settled by ``exact`` (None: never); the frame's times: the trace's as
        ``soft_*``, the G-buffer's share of the total apart."""
        result, ms = self.result, frame.ms
        inside = ms.get(UPSAMPLE, 0.0)
        ms[passes.GBUFFER] = ms.get(passes.TOTAL, 0.0) - inside - result.ms["total"]
        with self.timer.measure(UPSAMPLE):
            self.blocks.finish()
        with self.timer.measure(COMPOSITE):
            self.blocks.composite(composite, raster, target, self._clip_to_world, self.settings,
                                  radiance)
        refining = self.blocks.refining(self.settings)
        if refining is not None:
            with self.timer.measure(REFINE):
                maps = raster.refine_maps(self.settings, refine_phase(refining[0]),
                                          self._models)
                self.blocks.refine(composite, raster, target, self._clip_to_world,
                                   self.settings, maps, refining[1])
        elif exact is not None and self.blocks.settles:
            with self.timer.measure(SETTLE):
                if self.blocks.wants_gbuffer:
                    self._start_settling(target.size)
                self.blocks.settle_batch(exact, self._total(ms, inside))
        if read:
            frame.image = composite.read()
        ms.update({f"soft_{k}": v for k, v in result.ms.items()})
        total = self._total(ms, inside)
        for name in (COMPOSITE, UPSAMPLE, REFINE, SETTLE):
            ms[name] = self.timer.ms.get(name, 0.0)
        ms[passes.TOTAL] = total
        return result

    def _total(self, ms: dict, inside: float) -> float:
        """The frame's total so far: what ran before the shading pass's end (``ms``' total,
        which holds ``inside`` of the passes timed here), and the passes timed here since."""
        here = sum(self.timer.ms.get(name, 0.0) for name in (COMPOSITE, UPSAMPLE, REFINE, SETTLE))
        return ms.get(passes.TOTAL, 0.0) + here - inside

    def _start_settling(self, size: tuple[int, int]) -> None:
        """The scene drawn once more at the frame's ``size`` into a full G-buffer, whose
        positions and normals the settling keeps; the G-buffer is released."""
        gbuffer = FrameTarget(self.ctx, size, GBuffer.FULL)
        try:
            self._draw_points(gbuffer)
            w, h = size
            fb = gbuffer.framebuffer
            covered = np.frombuffer(fb.read(components=4, attachment=0), np.uint8)
            position, normal = (np.frombuffer(fb.read(components=4, attachment=k, dtype="f4"),
                                              np.float32).reshape(h, w, 4)[..., :3]
                                for k in (1, 2))
            self.blocks.start_settling(position, normal,
                                       covered.reshape(h, w, 4)[..., 3] > 0)
        finally:
            gbuffer.release()

    def visibility(self, composite: SoftComposite, raster: RasterSoft,
                   target: FrameTarget) -> np.ndarray:
        """The visibility the last frame lit each pixel by, (H, W), row 0 at the top; 0 where
        no geometry."""
        self.blocks.composite(composite, raster, target, self._clip_to_world, self.settings,
                              np.zeros(3), out_visibility=True)
        return composite.measured()

    def forget(self) -> None:
        """Keep none of the lookups a still view kept (:class:`StillLookups`)."""
        self.blocks.still.forget()

    def gl_objects(self) -> int:
        return self.blocks.gl_objects() + (self.points.gl_objects() if self.points else 0)

    def release(self) -> None:
        self.blocks.release()
        if self.points is not None:
            self.points.release()
            self.points = None
