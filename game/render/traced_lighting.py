"""Frames lit through traced visibility: the compute tracer over the G-buffer, then the soft
composite.

Two things use it: soft shadows of the scene's linear light, and the ``traced`` hard-shadow
method, whose exact visibility replaces the maps' (one ray per point toward the hard light).
"""

from __future__ import annotations

import numpy as np

from game.errors import GameError
from game.gpu import blocks
from game.gpu.timing import PassTimer
from game.render.frame import Frame
from game.render.target import FrameTarget
from game.scene.geometry import PackedGeometry
from game.scene.model import Scene
from game.soft.composite import SoftComposite
from game.soft.methods import EXACT_HARD, TraceSettings, hard_light
from game.soft.tracer import SoftTracer, TraceResult


class TracedLighting:
    """Owns the tracer (made on first use and kept, its static grid cached; a new
    ``cells_per_triangle`` makes a new one) and the composite. Times its passes with the
    renderer's ``timer``."""

    def __init__(self, ctx, defines: dict, scene: Scene, timer: PassTimer):
        self.ctx = ctx
        self.scene = scene
        self.timer = timer
        self.tracer: SoftTracer | None = None
        self.composite = SoftComposite(ctx, defines)

    def segment(self) -> tuple[int, np.ndarray, np.ndarray]:
        """The tracer's light tuple for the scene's linear light."""
        segment = self.scene.linear_light
        if segment is None:
            raise GameError("the scene has no [linear_light] to trace")
        return (blocks.TRACE_LIGHT_SEGMENT, segment.a, segment.b)

    def trace(self, target: FrameTarget, geom: PackedGeometry, models: np.ndarray,
              settings: TraceSettings, light: tuple | None = None) -> TraceResult:
        """Trace ``light`` (a tracer light tuple; default the linear light) from every G-buffer
        pixel of ``target``."""
        if not target.gbuffer:
            raise RuntimeError("the soft-shadow pass needs a renderer made with gbuffer=True")
        tracer = self.tracer
        if tracer is None or tracer.grid.cells_per_triangle != settings.cells_per_triangle:
            if tracer is not None:
                tracer.release()
            tracer = self.tracer = SoftTracer(self.ctx, geom, self.scene,
                                              settings.cells_per_triangle, self.timer.clock)
        textures = (target.position, target.normal, target.colour)
        return tracer.trace(textures, target.size, models, settings, light or self.segment())

    def light_frame(self, frame: Frame, target: FrameTarget, geom: PackedGeometry,
                    models: np.ndarray, soft: TraceSettings | None, read: bool) -> TraceResult:
        """Trace and light ``frame`` again: by the linear light through ``soft`` samples, or
        with ``soft`` None by the hard light's exact visibility (the ``traced`` method). The
        tracer's passes join the frame's times as ``soft_*`` or ``traced_*``; ``total`` grows
        by them and by the composite."""
        if soft is None:
            settings, light, soft_light, prefix = EXACT_HARD, hard_light(self.scene.light), None, \
                "traced"
        else:
            light = self.segment()
            settings, soft_light, prefix = soft, (light[1] + light[2]) / 2, "soft"
        result = self.trace(target, geom, models, settings, light)
        before = self.timer.ms.get("composite", 0.0)
        with self.timer.measure("composite"):
            self.composite.draw((target.position, target.normal, target.colour, target.shading,
                                 target.albedo), target.size,
                                result.visibility, blocks.LIGHT_KINDS[self.scene.light.kind],
                                hard=soft_light is None, soft_light=soft_light)
        if read:
            frame.image = self.composite.read()
        frame.ms.update({f"{prefix}_{k}": v for k, v in result.ms.items()})
        frame.ms["composite"] = self.timer.ms["composite"]
        frame.ms["total"] = (frame.ms.get("total", 0.0) + result.ms["total"]
                             + frame.ms["composite"] - before)
        return result

    def invalidate(self) -> None:
        """The geometry changed: the next trace builds its grid anew."""
        if self.tracer is not None:
            self.tracer.release()
            self.tracer = None

    def gl_objects(self) -> dict[str, int]:
        counts = {"composite": self.composite.gl_objects()}
        if self.tracer is not None:
            counts["tracer"] = self.tracer.gl_objects()
        return counts

    def release(self) -> None:
        self.invalidate()
        self.composite.release()
