"""The window's soft accumulation: a running mean of the traced visibility per pixel, on the GPU.

The reduced trace (game/soft/upsample.py) traces one pixel per block each frame. Here each
traced pixel's value joins its pixel's running mean, in a float texture of (mean, samples,
object index, distance from the camera) per pixel, two of them in turn (shaders/
soft_accumulate.frag). The picture shown (shaders/soft_resolve.frag) weighs the pixel's and its
3 x 3 neighbours' means by their samples and by the geometry (depth and normal), with this
frame's upsampled trace for the pixels that have few samples yet.

What starts again:
- every pixel, when the view (the camera, the frame's size, the trace's settings) changes;
- a pixel whose surface changed (another object, or another distance: a walker stepped in front
  of it or away from it);
- a pixel whose light triangle may cross a box a walker moved through since the last frame
  (:func:`walker_boxes`): its shadow may have moved. A walker's contact shadow therefore shows
  this frame's trace, never a trail of old frames.
"""

from __future__ import annotations

import moderngl
import numpy as np

from game.gpu import blocks, resources
from game.gpu.fullscreen import fullscreen_pass

# The most walkers' boxes one frame may name; more moved walkers than this start every pixel
# again instead.
MAX_BOXES = 64
# A history taken at another distance from the camera than the pixel's (as a share of it) is
# another surface.
DEPTH_TOLERANCE = 0.01
# Neighbours' weight halves once the pixel has this many samples of its own; from OWN_ENOUGH
# on, the pixel shows its own mean alone.
NEIGHBOUR_FADE = 2.0
OWN_ENOUGH = 4.0
# A moved walker's box grows by this share of its size on each side (its pose between frames).
BOX_MARGIN = 0.05
NO_SAMPLE = -1.0
UNITS = {"u_history": blocks.TEXTURE_UNITS["upsample_accumulated"],
         "u_position": blocks.TEXTURE_UNITS["trace_position"],
         "u_normal": blocks.TEXTURE_UNITS["trace_normal"],
         "u_colour": blocks.TEXTURE_UNITS["trace_colour"],
         "u_samples": blocks.TEXTURE_UNITS["upsample_samples"],
         "u_current": blocks.TEXTURE_UNITS["soft_visibility"]}


def walker_boxes(bounds: np.ndarray, before: np.ndarray | None, now: np.ndarray) -> np.ndarray:
    """Boxes (k, 2, 3) of centre and half size, one per walker that moved between the model
    matrices ``before`` and ``now`` (n, 4, 4): its local ``bounds`` (n, 2, 3) posed both ways,
    and the box around both. None ``before``: no walker moved (the first frame)."""
    if before is None or len(now) == 0 or before.shape != now.shape:
        return np.zeros((0, 2, 3))
    moved = np.any(np.abs(before - now) > 1e-9, axis=(1, 2))
    if not moved.any():
        return np.zeros((0, 2, 3))
    lo, hi = bounds[moved, 0], bounds[moved, 1]
    corners = np.stack([np.where(np.array([(i >> k) & 1 for k in range(3)], bool), hi, lo)
                        for i in range(8)], axis=1)                       # (k, 8, 3)
    homo = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=2)
    posed = np.concatenate([np.einsum("kij,kcj->kci", m[moved], homo)[..., :3]
                            for m in (before, now)], axis=1)
    low, high = posed.min(axis=1), posed.max(axis=1)
    half = (high - low) / 2 * (1 + 2 * BOX_MARGIN)
    return np.stack([(high + low) / 2, half], axis=1)


def write_boxes(prog, boxes: np.ndarray) -> None:
    """Set ``prog``'s u_boxes, u_box_centre and u_box_half (at most :data:`MAX_BOXES`) to
    ``boxes`` as :func:`walker_boxes` gives them."""
    prog["u_boxes"].value = len(boxes)
    if len(boxes):
        for name, part in (("u_box_centre", boxes[:, 0]), ("u_box_half", boxes[:, 1])):
            data = np.zeros((prog[name].array_length, 3), np.float32)
            data[:len(boxes)] = part
            prog[name].write(data.tobytes())


class Accumulation:
    """Owns the two history textures and their framebuffers, the accumulate and resolve
    programs and their vertex arrays; :meth:`release` releases them all."""

    def __init__(self, ctx, plane_sigma: float, normal_power: float):
        self.ctx = ctx
        self.size: tuple[int, int] | None = None
        self._targets: list = []
        self.history: list = []
        self._framebuffers: list = []
        self._current = 0
        self._accumulate = self._accumulate_vao = None
        self._resolve = self._resolve_vao = None
        try:
            self._accumulate, self._accumulate_vao = fullscreen_pass(
                ctx, "soft_accumulate.frag", {"NO_SAMPLE": NO_SAMPLE, "MAX_BOXES": MAX_BOXES,
                                              "DEPTH_TOLERANCE": DEPTH_TOLERANCE})
            self._resolve, self._resolve_vao = fullscreen_pass(
                ctx, "soft_resolve.frag", {"NO_SAMPLE": NO_SAMPLE, "PLANE_SIGMA": plane_sigma,
                                           "NORMAL_POWER": normal_power,
                                           "NEIGHBOUR_FADE": NEIGHBOUR_FADE,
                                           "OWN_ENOUGH": OWN_ENOUGH})
        except BaseException:
            self.release()
            raise

    def resize(self, size: tuple[int, int]) -> None:
        """Make the history anew at ``size`` (nothing accumulated)."""
        if size == self.size:
            return
        self._release_targets()
        self.size = size
        self.history = [self.ctx.texture(size, 4, dtype="f4") for _ in range(2)]
        for tex in self.history:
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._framebuffers = [self.ctx.framebuffer([tex]) for tex in self.history]
        self._targets = [*self._framebuffers, *self.history]
        self._current = 0

    def accumulate(self, textures, samples, mapping: dict, reset: bool, boxes: np.ndarray,
                   camera: np.ndarray, light: tuple) -> None:
        """Add this frame's traced pixels to the history. ``textures``: the frame's (position,
        normal, colour); ``samples``: the reduced trace's texture (w: visibility), laid out as
        ``mapping`` says (``divisor``, ``phase``, ``shift``, ``cells``, ``traced``);
        ``boxes`` as :func:`walker_boxes` gives them; ``light`` the segment's (mode, a, b)."""
        prog = self._accumulate
        reset = reset or len(boxes) > MAX_BOXES
        boxes = boxes[:MAX_BOXES] if not reset else boxes[:0]
        self._bind(prog, {"u_history": self.history[self._current], "u_position": textures[0],
                          "u_colour": textures[2], "u_samples": samples})
        prog["u_divisor"].value = mapping["divisor"]
        prog["u_phase"].value = tuple(mapping["phase"])
        prog["u_shift"].value = mapping["shift"]
        prog["u_cells"].value = tuple(mapping["cells"])
        prog["u_traced"].value = mapping["traced"]
        prog["u_reset"].value = reset
        prog["u_camera"].value = tuple(float(x) for x in camera)
        prog["u_light_a"].value = tuple(float(x) for x in light[1])
        prog["u_light_b"].value = tuple(float(x) for x in light[2])
        write_boxes(prog, boxes)
        self._current = 1 - self._current
        self._draw(self._framebuffers[self._current], self._accumulate_vao)

    def resolve(self, textures, current, framebuffer) -> None:
        """The picture into ``framebuffer`` (the frame's size): the history filtered along the
        geometry, with ``current`` (this frame's upsampled trace) where samples are few."""
        self._bind(self._resolve, {"u_history": self.history[self._current],
                                   "u_current": current, "u_position": textures[0],
                                   "u_normal": textures[1], "u_colour": textures[2]})
        self._draw(framebuffer, self._resolve_vao)

    @property
    def latest(self):
        """The history texture this frame wrote (the upsample reads its samples)."""
        return self.history[self._current]

    def read(self) -> np.ndarray:
        """The history, (H, W, 4) float32 with row 0 at the top (tests, the measurements)."""
        w, h = self.size
        data = np.frombuffer(self.history[self._current].read(), np.float32)
        return data.reshape(h, w, 4)[::-1].copy()

    def _bind(self, prog, textures: dict) -> None:
        for name, tex in textures.items():
            if name in prog:   # the compiler drops what a program does not read
                tex.use(UNITS[name])
                prog[name].value = UNITS[name]

    def _draw(self, framebuffer, vao) -> None:
        framebuffer.use()
        framebuffer.viewport = (0, 0, *self.size)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)

    def gl_objects(self) -> int:
        programs = [p for p in (self._accumulate, self._resolve) if p is not None]
        return 2 * len(programs) + resources.attached_shaders(programs) + len(self._targets)

    def _release_targets(self) -> None:
        resources.release_targets(self.ctx, self._targets)
        self._targets, self.history, self._framebuffers = [], [], []
        self.size = None

    def release(self) -> None:
        self._release_targets()
        for obj in (self._accumulate_vao, self._accumulate, self._resolve_vao, self._resolve):
            if obj is not None:
                obj.release()
        self._accumulate = self._accumulate_vao = self._resolve = self._resolve_vao = None
