"""Frames lit through traced visibility: the compute tracer over the G-buffer, then the soft
composite.

Two things use it: soft shadows of the scene's linear light, and the ``traced`` hard-shadow
method, whose exact visibility replaces the maps' (one ray per point toward the hard light).
"""

from __future__ import annotations

import numpy as np

from game.gpu import blocks
from game.render.target import FrameTarget
from game.scene.geometry import PackedGeometry
from game.scene.model import Scene
from game.soft.composite import SoftComposite
from game.soft.methods import TraceSettings
from game.soft.tracer import SoftTracer, TraceResult


class TracedLighting:
    """Owns the tracer (made on first use and kept, its static grid cached; a new
    ``cells_per_triangle`` makes a new one) and the composite."""

    def __init__(self, ctx, defines: dict, clock: str):
        self.ctx = ctx
        self.clock = clock
        self.tracer: SoftTracer | None = None
        self.composite = SoftComposite(ctx, defines)

    def trace(self, target: FrameTarget, geom: PackedGeometry, scene: Scene, models: np.ndarray,
              settings: TraceSettings, light: tuple[int, np.ndarray, np.ndarray]) -> TraceResult:
        """Trace ``light`` (a tracer light tuple) from every G-buffer pixel of ``target``."""
        if not target.gbuffer:
            raise RuntimeError("the soft-shadow pass needs a renderer made with gbuffer=True")
        tracer = self.tracer
        if tracer is None or tracer.grid.cells_per_triangle != settings.cells_per_triangle:
            if tracer is not None:
                tracer.release()
            tracer = self.tracer = SoftTracer(self.ctx, geom, scene, settings.cells_per_triangle,
                                              self.clock)
        textures = (target.position, target.normal, target.colour)
        return tracer.trace(textures, target.size, models, settings, light)

    def light(self, target: FrameTarget, result: TraceResult, light_kind: str,
              soft_light: np.ndarray | None) -> None:
        """Light the frame in ``target`` through ``result``: by the linear light from
        ``soft_light`` (its midpoint), or with ``soft_light`` None by the hard light."""
        self.composite.draw((target.position, target.normal, target.colour), target.size,
                            result.visibility, blocks.LIGHT_KINDS[light_kind],
                            hard=soft_light is None, soft_light=soft_light)

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
