"""The records of one frame: where the camera is (:class:`View`), what was made (:class:`Frame`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from game import transforms
from game.scene.model import Camera
from game.shadows.plan import CharacterCounts
from game.soft.tracer import TraceResult


@dataclass
class View:
    """Where the camera is this frame."""

    view: np.ndarray   # (4, 4) world -> view
    proj: np.ndarray   # (4, 4) view -> clip
    size: tuple[int, int] | None = None  # pixels (width, height); the renderer fills it in

    @staticmethod
    def from_camera(camera: Camera, size: tuple[int, int]) -> View:
        aspect = size[0] / size[1]
        return View(transforms.look_at(camera.position, camera.target),
                    transforms.perspective(camera.fov, aspect, camera.near, camera.far), size)


def plan_counts(plan, triangles: int, first=None) -> dict:
    """The frame's counts of maps, triangles and texels drawn from its plan
    (:class:`~game.shadows.plan.ShadowPlan`); ``first`` is a plan drawn before it in the same
    frame, whose renders count too."""
    rendered = len(plan.render_static) + len(plan.render_dynamic)
    drawn = (*plan.render_static, *plan.render_dynamic)
    texels = sum(plan.maps[i].viewport ** 2 for i in drawn)
    again = (*first.render_static, *first.render_dynamic) if first is not None else ()
    texels += sum(first.maps[i].viewport ** 2 for i in again)
    return {"maps_rendered": rendered + len(again),
            "maps_cached": len(plan.maps) - rendered,
            "maps_total": len(plan.maps), "triangles_to_maps": triangles,
            "texels_to_maps": texels,
            "maps_waiting": plan.backlog,
            "characters": plan.characters}


@dataclass
class Frame:
    """What one rendered frame produced."""

    # The next three are None when the frame was rendered with ``read=False`` (the window
    # shows the renderer's display texture instead of reading it back).
    image: np.ndarray | None          # (H, W, 3) uint8, row 0 at the top
    covered: np.ndarray | None        # (H, W) bool: geometry under the pixel centre
    maps_sampled: np.ndarray | None   # (H, W) int: shadow maps read for the pixel
    ms: dict[str, float]
    maps_rendered: int
    maps_cached: int
    maps_total: int
    triangles_to_maps: int
    gbuffer: dict[str, np.ndarray] | None = None  # position, normal, object, lit (and soft)
    gl_objects: dict[str, int] | None = None  # live GL objects by owner, after the frame
    texels_to_maps: int = 0    # depth texels cleared and rendered into maps this frame
    maps_waiting: int = 0      # view-sized clump maps whose new side waits for a later frame
    characters: CharacterCounts | None = None  # the character maps (ShadowPlan.characters)
    camera_triangles: int = 0  # triangles the camera pass drew (after culling)
    soft: TraceResult | None = None  # the linear light's trace, when the frame asked for one
    # (H, W) int: map records each pixel considered, read or not (Renderer.count_candidates).
    map_candidates: np.ndarray | None = None
    depth_first: bool = False  # the camera pass drew its depth before it shaded
    # Fragments that passed the depth test in the scene's order, per pixel of the picture, in
    # the draw before this frame's (None before the first, or with --depth-first on or off).
    fragments_per_pixel: float | None = None

    @property
    def map_candidates_per_fragment(self) -> float | None:
        """The map records a covered pixel considered, on average: what finding its maps
        costs, where :attr:`maps_per_fragment` counts only the maps it read."""
        if self.covered is None or self.map_candidates is None:
            return None
        n = int(self.covered.sum())
        return float(self.map_candidates[self.covered].sum()) / n if n else 0.0

    @property
    def maps_per_fragment(self) -> float | None:
        if self.covered is None:
            return None
        n = int(self.covered.sum())
        return float(self.maps_sampled[self.covered].sum()) / n if n else 0.0
