"""What the tracer's tests share: traces over a G-buffer or chosen points, Embree beside them,
and small scenes written as text."""

from __future__ import annotations

import numpy as np

from game.app import dumps
from game.gpu.blocks import TRACE_LIGHT_SEGMENT
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.scene import geometry, parse_scene
from game.soft import grid as trace_grid
from game.soft.tracer import (
    RAY_OFFSET_DISTANCE,
    RAY_OFFSET_SCENE,
    SoftTracer,
    TraceSettings,
)

SIZE = (96, 54)
ACCELERATED = ("grid", "tri-cache", "voxel-cache")
ALL = ("brute", *ACCELERATED)


def gbuffer_trace(ctx, scene, methods, samples, size=SIZE, t=0.0, **settings):
    """Render the G-buffer once and trace it with each method; returns (frame, results)."""
    r = Renderer(ctx, scene, size, gbuffer=True)
    try:
        frame = r.render(t, View.from_camera(scene.camera, size))
        results = {m: r.trace(t, TraceSettings(method=m, samples=samples, **settings))
                   for m in methods}
        diagonal = r.soft_tracer.grid.spec.diagonal
    finally:
        r.release()
    return frame, results, diagonal


def embree_of(scene, t=0.0):
    return sr.EmbreeOccluder(dumps.frame_geometry(scene, t).to_geometry())


def origins_of(frame, diagonal):
    g = frame.gbuffer
    covered = np.isfinite(g["position"]).all(axis=-1)
    pts, nrm = g["position"][covered], g["normal"][covered]
    return covered, sr.ray_origins(pts, nrm, RAY_OFFSET_SCENE * diagonal, RAY_OFFSET_DISTANCE), nrm


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)))


def scene_text(boxes, a, b, floor=True, scale=1.0):
    """A scene of boxes (size, position) and a linear light, all scaled by ``scale``."""
    def v(x):
        return "[" + ", ".join(repr(float(c) * scale) for c in x) + "]"

    parts = ['[camera]\nposition = ' + v([0, 6, 10]) + '\ntarget = ' + v([0, 0, 0])
             + f'\nfov = 60.0\nnear = {0.1 * scale}\nfar = {200.0 * scale}\n',
             '[light]\nkind = "directional"\ndirection = [-0.4, -1.0, -0.3]\n',
             f"[linear_light]\na = {v(a)}\nb = {v(b)}\n"]
    if floor:
        parts.append(f'[[floor]]\nshape = "box"\nsize = {v([30, 0.2, 30])}\n'
                     f'position = {v([0, -0.1, 0])}\n')
    for size, position in boxes:
        parts.append(f'[[static]]\nshape = "box"\nsize = {v(size)}\nposition = {v(position)}\n')
    return "\n".join(parts)


class Points:
    """A tracer over a scene for chosen points (no G-buffer render)."""

    def __init__(self, ctx, text, structure=trace_grid.DEFAULT_STRUCTURE,
                 cells_per_triangle=trace_grid.CELLS_PER_TRIANGLE):
        self.scene = parse_scene(text)
        self.geom = geometry.pack(self.scene)
        self.structure = structure
        self.tracer = SoftTracer(ctx, self.geom, self.scene, cells_per_triangle,
                                 structure=structure)

    def __call__(self, method, points, normals, samples=16, light=None):
        seg = self.scene.linear_light
        light = light or (TRACE_LIGHT_SEGMENT, seg.a, seg.b)
        points = np.asarray(points, np.float32)
        normals = np.broadcast_to(np.asarray(normals, np.float32), points.shape)
        result = self.tracer.trace_points(
            points, normals, np.zeros((0, 4, 4)),
            TraceSettings(method=method, samples=samples, structure=self.structure), light)
        return result

    def release(self):
        self.tracer.release()


def check_all_equal_brute(tracer, points, normals, samples=16, light=None):
    brute = tracer("brute", points, normals, samples, light).visibility
    for m in ACCELERATED:
        np.testing.assert_array_equal(tracer(m, points, normals, samples, light).visibility,
                                      brute, err_msg=m)
    return brute


def sphere_field_text(rows: int, spacing: float, radius: float, height: float) -> str:
    """A floor under a rows x rows field of spheres (320 triangles each) and a linear light."""
    text = scene_text([], [-4.0, 7.0, -1.0], [4.0, 7.0, 1.0])
    half = (rows - 1) * spacing / 2
    for i in range(rows):
        for j in range(rows):
            x, z = i * spacing - half, j * spacing - half
            text += (f'\n[[static]]\nshape = "sphere"\nradius = {radius}\n'
                     f"position = [{x}, {height}, {z}]\n")
    return text


