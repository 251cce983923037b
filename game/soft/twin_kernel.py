"""The numba kernels of the CPU twin (game/soft/cpu_twin.py): shaders/trace.comp's sampled
methods, line for line, in float32 on the CPU.

Every float is a float32 and every operation is written in the shader's order, so that the twin
casts the shader's very rays: the same origin, samples, watertight ray-triangle test, 3D-DDA over
one or two grid levels, mailbox, per-triangle words (``tri-cache``) and per-point voxel cache
(``voxel-cache``). Vectors are tuples, which numba keeps in registers, so the memory a kernel
reads is the structure's: the triangles, the leaf pairs and lists, the per-triangle words, the
voxel cache and the mailbox.

Counters (``count``): the shader's ``PointResult`` counters, in the order of
:data:`COUNTER_NAMES`. With ``count`` off the kernels store none of them, so that a cache
simulation sees the method's own memory accesses only.

The walks over the grid and the points are in game/soft/twin_walk.py. Both need numba;
game/soft/cpu_twin.py imports them only when asked to trace.
"""

from __future__ import annotations

import numpy as np
from numba import njit

BRUTE, GRID, TRI_CACHE, VOXEL_CACHE = 0, 1, 2, 3  # METHOD_* of game/soft/methods.py
COUNTER_NAMES = ("ray_triangle_tests", "triangle_triangle_tests", "voxels_visited",
                 "candidates", "overflows", "bytes_triangles", "bytes_cells", "bytes_candidates")
RT, TT, VOX, CAND, OVER, BT, BC, BK = range(8)
TRIANGLE_BYTES = 48  # three vec4 per triangle, as in the Triangles buffer

F0 = np.float32(0.0)
F1 = np.float32(1.0)
BIG = np.float32(1e30)
EPS = np.float32(1e-4)    # CONSERVATIVE_EPS of shaders/trace.glsl
TINY = np.float32(1e-30)
# No reference counting: the kernels allocate nothing (the caller hands them their scratch), and
# numba's counts on every array taken from a tuple would be most of a ray's instructions.
JIT = {"cache": True, "error_model": "numpy", "nogil": True, "_nrt": False}


@njit(inline="always", **JIT)
def _pick(v, k):
    return v[0] if k == 0 else (v[1] if k == 1 else v[2])


@njit(inline="always", **JIT)
def _with(v, k, x):
    return (x, v[1], v[2]) if k == 0 else ((v[0], x, v[2]) if k == 1 else (v[0], v[1], x))


@njit(inline="always", **JIT)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(inline="always", **JIT)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(inline="always", **JIT)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(inline="always", **JIT)
def _length(a):
    return np.sqrt(_dot(a, a))


@njit(inline="always", **JIT)
def _vertex(tris, tri, k):
    b = 12 * tri + 4 * k
    return (tris[b], tris[b + 1], tris[b + 2])


# ---- the watertight ray-triangle test (Woop, Benthin and Wald 2013), as trace.glsl --------------
@njit(inline="always", **JIT)
def make_ray(d):
    ax, ay, az = abs(d[0]), abs(d[1]), abs(d[2])
    kz = (0 if ax > az else 2) if ax > ay else (1 if ay > az else 2)
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    dz = _pick(d, kz)
    if dz < F0:
        kx, ky = ky, kx
    return (kx, ky, kz), (_pick(d, kx) / dz, _pick(d, ky) / dz, F1 / dz)


@njit(inline="always", **JIT)
def ray_hits(tris, tri, o, k, shear):
    kx, ky, kz = k
    b = 12 * tri
    akx, aky, akz = tris[b + kx] - o[kx], tris[b + ky] - o[ky], tris[b + kz] - o[kz]
    bkx, bky, bkz = tris[b + 4 + kx] - o[kx], tris[b + 4 + ky] - o[ky], tris[b + 4 + kz] - o[kz]
    ckx, cky, ckz = tris[b + 8 + kx] - o[kx], tris[b + 8 + ky] - o[ky], tris[b + 8 + kz] - o[kz]
    sx, sy, sz = shear
    ax_, ay_ = akx - sx * akz, aky - sy * akz
    bx_, by_ = bkx - sx * bkz, bky - sy * bkz
    cx_, cy_ = ckx - sx * ckz, cky - sy * ckz
    u = cx_ * by_ - cy_ * bx_
    v = ax_ * cy_ - ay_ * cx_
    w = bx_ * ay_ - by_ * ax_
    if (u < F0 or v < F0 or w < F0) and (u > F0 or v > F0 or w > F0):
        return False
    det = u + v + w
    t = u * (sz * akz) + v * (sz * bkz) + w * (sz * ckz)
    if det < F0:
        t, det = -t, -det
    return det > F0 and t > F0 and t < det


# ---- the conservative triangle-triangle test (triangles_may_meet), as trace.glsl ----------------
@njit(**JIT)
def _separated_on(axis, p0, p1, p2, q0, q1, q2, scale):
    len2 = _dot(axis, axis)
    if len2 <= TINY * scale * scale * scale * scale:
        return False
    a0, a1, a2 = _dot(axis, p0), _dot(axis, p1), _dot(axis, p2)
    b0, b1, b2 = _dot(axis, q0), _dot(axis, q1), _dot(axis, q2)
    tol = EPS * np.sqrt(len2) * scale
    return (min(min(b0, b1), b2) > max(max(a0, a1), a2) + tol
            or max(max(b0, b1), b2) < min(min(a0, a1), a2) - tol)


@njit(**JIT)
def triangles_may_meet(p0, p1, p2, q0, q1, q2):
    p1, p2 = _sub(p1, p0), _sub(p2, p0)
    q0, q1, q2 = _sub(q0, p0), _sub(q1, p0), _sub(q2, p0)
    p0 = (F0, F0, F0)
    scale = max(max(max(_length(p1), _length(p2)), max(_length(q0), _length(q1))), _length(q2))
    ep = (_sub(p1, p0), _sub(p2, p1), _sub(p0, p2))
    eq = (_sub(q1, q0), _sub(q2, q1), _sub(q0, q2))
    if _separated_on(_cross(ep[0], ep[1]), p0, p1, p2, q0, q1, q2, scale):
        return False
    if _separated_on(_cross(eq[0], eq[1]), p0, p1, p2, q0, q1, q2, scale):
        return False
    for i in range(3):
        for j in range(3):
            if _separated_on(_cross(ep[i], eq[j]), p0, p1, p2, q0, q1, q2, scale):
                return False
    return True


# ---- per-ray and per-point state -----------------------------------------------------------
@njit(inline="always", **JIT)
def _mailbox_seen(mailbox, box, tri):
    """True if the ray tested ``tri`` already; else remembers it (box[0]: the next slot)."""
    m = len(mailbox)
    for i in range(m):
        if mailbox[i] == tri:
            return True
    mailbox[box[0]] = tri
    box[0] = (box[0] + 1) % m
    return False


@njit(inline="always", **JIT)
def _test_tri(tris, tri, o, k, shear, mailbox, box, cnt, count):
    if _mailbox_seen(mailbox, box, tri):
        return False
    if count:
        cnt[RT] += 1
        cnt[BT] += TRIANGLE_BYTES
    return ray_hits(tris, tri, o, k, shear)


@njit(inline="always", **JIT)
def _may_occlude(tris, tri, light, cnt, count):
    if count:
        cnt[TT] += 1
        cnt[BT] += TRIANGLE_BYTES
    return triangles_may_meet(light[0], light[1], light[2], _vertex(tris, tri, 0),
                              _vertex(tris, tri, 1), _vertex(tris, tri, 2))


@njit(inline="always", **JIT)
def _leaf_tri(static, dynamic, k, s0, d0, ns, cnt, count):
    if count:
        cnt[BC] += 4
    return static[s0 + k] if k < ns else dynamic[d0 + k - ns]


# ---- the leaf walks of the methods ---------------------------------------------------------------
@njit(inline="always", **JIT)
def _list_walk(tris, static, dynamic, s0, d0, ns, n, ray, st, cnt, count):
    """Every triangle of a leaf (grid; voxel-cache's overflow path)."""
    o, k, shear = ray
    mailbox, box = st[0], st[1]
    for j in range(n):
        if _test_tri(tris, _leaf_tri(static, dynamic, j, s0, d0, ns, cnt, count), o, k, shear,
                     mailbox, box, cnt, count):
            return True
    return False


@njit(inline="always", **JIT)
def _tri_cache_walk(tris, static, dynamic, s0, d0, ns, n, ray, light, ray_id, st, cnt, count):
    """A leaf's triangles that may meet the light triangle, remembered by a (ray id, flag) word
    per triangle, shared by every point (the scheme [643] of the note)."""
    o, k, shear = ray
    mailbox, box, words = st[0], st[1], st[2]
    for j in range(n):
        tri = _leaf_tri(static, dynamic, j, s0, d0, ns, cnt, count)
        if count:
            cnt[BK] += 4
        state = words[tri]
        if (state >> np.uint32(1)) == ray_id:
            may = (state & np.uint32(1)) == np.uint32(0)
        else:
            may = _may_occlude(tris, tri, light, cnt, count)
            if count:
                cnt[BK] += 4
            words[tri] = (ray_id << np.uint32(1)) | (np.uint32(0) if may else np.uint32(1))
        if may and _test_tri(tris, tri, o, k, shear, mailbox, box, cnt, count):
            return True
    return False


@njit(inline="always", **JIT)
def _voxel_cache_build(tris, static, dynamic, s0, d0, ns, n, leaf, slot, light, st, cnt, count):
    """The leaf's candidates into the point's pool, the first time its rays enter the leaf."""
    key, start, size, pool, used = st[3], st[4], st[5], st[6], st[7]
    if used[0] + n > len(pool):
        for i in range(len(key)):
            key[i] = 0
        used[0] = 0
    key[slot] = leaf + 1
    start[slot] = used[0]
    if count:
        cnt[BK] += 12
    found = 0
    for j in range(n):
        tri = _leaf_tri(static, dynamic, j, s0, d0, ns, cnt, count)
        if _may_occlude(tris, tri, light, cnt, count):
            if used[0] + found < len(pool):
                pool[used[0] + found] = tri
                if count:
                    cnt[BK] += 4
            found += 1
    if count:
        cnt[CAND] += found
    if used[0] + found > len(pool):
        if count:
            cnt[OVER] += 1
        size[slot] = -1
    else:
        size[slot] = found
        used[0] += found


@njit(inline="always", **JIT)
def _voxel_cache_walk(tris, static, dynamic, s0, d0, ns, n, leaf, ray, light, big, st, cnt,
                      count):
    """The note's per-voxel scheme with per-point state: a direct-mapped table of leaves whose
    candidates sit in a bump-allocated pool (shaders/trace_leaf_voxel_cache.glsl)."""
    if n == 0:
        return False
    key, start, size, pool = st[3], st[4], st[5], st[6]
    slot = leaf & (len(key) - 1)
    raw = n > big
    if raw:
        if count:
            cnt[OVER] += 1
    else:
        if count:
            cnt[BK] += 4
        if key[slot] != leaf + 1:
            _voxel_cache_build(tris, static, dynamic, s0, d0, ns, n, leaf, slot, light, st, cnt,
                               count)
        if count:
            cnt[BK] += 8
        raw = size[slot] < 0
    if raw:
        return _list_walk(tris, static, dynamic, s0, d0, ns, n, ray, st, cnt, count)
    o, k, shear = ray
    mailbox, box = st[0], st[1]
    first = start[slot]
    for j in range(size[slot]):
        if count:
            cnt[BK] += 4
        if _test_tri(tris, pool[first + j], o, k, shear, mailbox, box, cnt, count):
            return True
    return False
