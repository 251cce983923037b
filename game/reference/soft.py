"""The independent reference for the linear light: dense stratified Embree shadow rays.

Like game/reference/hard.py it shares no GL and no grid with the tracer it judges: Embree's BVH and
ray-triangle test on the CPU. It also builds the tracer's own sample rays (the numpy twin of
``sample_t`` in shaders/trace.glsl), so that Embree's any-hit can be timed on the very rays a
method traced, side by side.
"""

from __future__ import annotations

import time

import numpy as np
import trimesh

from game.reference.hard import EMBREE_HINT

# Rays per Embree call: bounds the memory of 1024-sample references.
RAYS_PER_BATCH = 2_000_000


class EmbreeOccluder:
    """An Embree scene of one mesh, built once; any-hit queries on ray segments."""

    def __init__(self, mesh: trimesh.Trimesh):
        try:
            from embreex import rtcore_scene
            from embreex.mesh_construction import TriangleMesh
        except ImportError as error:
            raise RuntimeError(EMBREE_HINT) from error
        # Embree works in float32: recentre on the scene so coordinates stay small and precise.
        self.centre = mesh.bounds.mean(axis=0)
        self.scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene=self.scene, vertices=(mesh.vertices - self.centre).astype(np.float32),
                     indices=np.asarray(mesh.faces, dtype=np.int32))
        self.seconds = 0.0  # time spent in queries (the BVH build is excluded)
        self.rays = 0

    def occluded(self, origins: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """Is anything strictly between each origin and its target? (N,) bool."""
        out = np.zeros(len(origins), bool)
        for start in range(0, len(origins), RAYS_PER_BATCH):
            o = origins[start:start + RAYS_PER_BATCH].astype(np.float64)
            d = targets[start:start + RAYS_PER_BATCH].astype(np.float64) - o
            dist = np.linalg.norm(d, axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                unit = d / dist[:, None]
            o32 = (o - self.centre).astype(np.float32)
            u32 = np.ascontiguousarray(unit, dtype=np.float32)
            far = dist.astype(np.float32)
            t0 = time.perf_counter()
            hits = self.scene.run(o32, u32, dists=far, query="OCCLUDED")
            self.seconds += time.perf_counter() - t0
            self.rays += len(o32)
            # embreex answers OCCLUDED with 0 for a blocked ray and -1 for a free one.
            out[start:start + len(o32)] = np.asarray(hits) != -1
        return out


def pcg(v: np.ndarray) -> np.ndarray:
    """PCG hash on uint32, the twin of ``pcg`` in shaders/trace.glsl."""
    v = np.asarray(v, np.uint32)
    with np.errstate(over="ignore"):
        state = v * np.uint32(747796405) + np.uint32(2891336453)
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(
            277803737)
    return (word >> np.uint32(22)) ^ word


def tracer_samples(point_index: np.ndarray, n: int) -> np.ndarray:
    """(P, n) float32 segment parameters the tracer uses: the twin of ``sample_t``."""
    point = np.asarray(point_index, np.uint32)[:, None]
    i = np.arange(n, dtype=np.uint32)[None, :]
    with np.errstate(over="ignore"):
        h = pcg((point * np.uint32(2654435769)) ^ pcg(i))
    jitter = (h >> np.uint32(8)).astype(np.float32) * np.float32(1.0 / 16777216.0)
    return (i.astype(np.float32) + jitter) / np.float32(n)


def ray_origins(points: np.ndarray, normals: np.ndarray, offset_m: float,
                offset_per_m: float) -> np.ndarray:
    """Points pushed off their surface along the normal, by the tracer's rule."""
    p = np.asarray(points, np.float64)
    n = np.asarray(normals, np.float64)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    eps = offset_m + offset_per_m * np.linalg.norm(p, axis=1)
    return p + n * eps[:, None]


def segment_visibility(occluder: EmbreeOccluder, origins: np.ndarray, normals: np.ndarray,
                       a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Visible share of the samples ``t`` (P, n) of the segment a-b from each origin.

    Samples below the receiver's horizon (N . (L - o) <= 0) count as hidden, as in the tracer.
    """
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    p, n = t.shape
    targets = a[None, None, :] + t[..., None].astype(np.float64) * (b - a)[None, None, :]
    o = np.broadcast_to(origins[:, None, :], targets.shape)
    up = np.einsum("psk,pk->ps", targets - o, normals) > 0.0
    visible = np.zeros((p, n), bool)
    if up.any():
        visible[up] = ~occluder.occluded(o[up], targets[up])
    return visible.mean(axis=1)


def stratified_reference(occluder: EmbreeOccluder, origins: np.ndarray, normals: np.ndarray,
                         a: np.ndarray, b: np.ndarray, samples: int = 1024,
                         seed: int = 0) -> np.ndarray:
    """Visibility from ``samples`` stratified samples with independent random jitter."""
    rng = np.random.default_rng(seed)
    out = np.zeros(len(origins))
    chunk = max(1, RAYS_PER_BATCH // samples)
    for start in range(0, len(origins), chunk):
        o = origins[start:start + chunk]
        jitter = rng.random((len(o), samples))
        t = (np.arange(samples)[None, :] + jitter) / samples
        out[start:start + chunk] = segment_visibility(occluder, o, normals[start:start + chunk],
                                                      a, b, t)
    return out
