"""The CPU twin's walks (game/soft/cpu_twin.py): the 3D-DDA over one or two grid levels
(shaders/trace_ray_walk.glsl), brute force, and the loop over points and samples of
shaders/trace.comp, in float32 and the shader's order of operations. The tests and leaf walks it
calls are in game/soft/twin_kernel.py. Needs numba.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from game.soft.twin_kernel import (
    BC,
    BIG,
    BRUTE,
    BT,
    COUNTER_NAMES,  # noqa: F401  (re-exported: cpu_twin reads it here)
    F0,
    F1,
    JIT,
    RT,
    TRI_CACHE,
    TRIANGLE_BYTES,
    VOX,
    VOXEL_CACHE,
    _dot,
    _length,
    _list_walk,
    _sub,
    _tri_cache_walk,
    _voxel_cache_walk,
    _with,
    make_ray,
    ray_hits,
)


# ---- the 3D-DDA over one or two grid levels (trace_ray_walk.glsl) -----------------------------
@njit(inline="always", **JIT)
def _exit_on(lo, size, c, o, inv, step):
    """The ray parameter of the cell's far face on one axis (1e30 where the ray is parallel)."""
    if step == 0:
        return BIG
    face = lo + (np.float32(c) + (F1 if step > 0 else F0)) * size
    return (face - o) * inv


@njit(inline="always", **JIT)
def _cell_exit(lo, size, c, o, inv, step):
    return (_exit_on(lo[0], size[0], c[0], o[0], inv[0], step[0]),
            _exit_on(lo[1], size[1], c[1], o[1], inv[1], step[1]),
            _exit_on(lo[2], size[2], c[2], o[2], inv[2], step[2]))


@njit(inline="always", **JIT)
def _index_on(x, box, size, dims):
    return min(max(int(np.floor((x - box) / size)), 0), dims - 1)


@njit(inline="always", **JIT)
def _cell_at(x, box, size, dims):
    """clamp(ivec3(floor((x - box) / size)), 0, dims - 1)."""
    return (_index_on(x[0], box[0], size[0], dims[0]), _index_on(x[1], box[1], size[1], dims[1]),
            _index_on(x[2], box[2], size[2], dims[2]))


@njit(inline="always", **JIT)
def _span(o, d, lo, hi):
    """The ray's [s0, s1] in the grid's box, its 1/d and the signs of d."""
    inv = (F1 / d[0], F1 / d[1], F1 / d[2])
    step = (int(np.sign(d[0])), int(np.sign(d[1])), int(np.sign(d[2])))
    s0, s1 = F0, F1
    for a in range(3):
        if d[a] == F0:
            within = o[a] >= lo[a] and o[a] <= hi[a]
            tn, tf = (-BIG, BIG) if within else (BIG, -BIG)
        else:
            t0, t1 = (lo[a] - o[a]) * inv[a], (hi[a] - o[a]) * inv[a]
            tn, tf = min(t0, t1), max(t0, t1)
        s0, s1 = max(s0, tn), min(s1, tf)
    return s0, s1, inv, step


@njit(inline="always", **JIT)
def _leaf(tris, static, dynamic, leaf, ray, light, method, ray_id, big, st, cnt, count):
    """The leaf's triangles by the method: True if one hides the sample."""
    s0, ns, d0 = static[2 * leaf], static[2 * leaf + 1], dynamic[2 * leaf]
    n = ns + dynamic[2 * leaf + 1]
    if count:
        cnt[BC] += 16
        cnt[VOX] += 1
    if method == TRI_CACHE:
        return _tri_cache_walk(tris, static, dynamic, s0, d0, ns, n, ray, light, ray_id, st, cnt,
                               count)
    if method == VOXEL_CACHE:
        return _voxel_cache_walk(tris, static, dynamic, s0, d0, ns, n, leaf, ray, light, big, st,
                                 cnt, count)
    return _list_walk(tris, static, dynamic, s0, d0, ns, n, ray, st, cnt, count)


# long: one loop over both levels, as the shader's grid_walk; its state is the GridWalk struct
@njit(**JIT)
def grid_walk(tris, static, dynamic, grid, o, d, ray, light, method, ray_id, big, st, cnt,
              count):
    """True if a triangle in the leaves along the ray o + s d, 0 < s < 1, hides it."""
    origin, cell, gdims = grid
    hi = (origin[0] + cell[0] * np.float32(gdims[0]), origin[1] + cell[1] * np.float32(gdims[1]),
          origin[2] + cell[2] * np.float32(gdims[2]))
    s0, s1, inv, step = _span(o, d, origin, hi)
    if s0 > s1:
        return False
    dims, box, size, first, inside = gdims, origin, cell, 0, False
    s_in = s0
    x = (o[0] + d[0] * s0, o[1] + d[1] * s0, o[2] + d[2] * s0)
    c = _cell_at(x, origin, cell, gdims)
    top = c
    while True:
        leaf = first + c[0] + dims[0] * (c[1] + dims[1] * c[2])
        if static[2 * leaf + 1] < 0:
            # A subdivided top cell: on into its sub-grid, at the cell where the ray enters.
            if count:
                cnt[BC] += 16
            bits = -1 - static[2 * leaf + 1]
            first = static[2 * leaf]
            inside, top = True, c
            dims = (bits & 63, (bits >> 6) & 63, bits >> 12)
            box = (origin[0] + np.float32(c[0]) * cell[0], origin[1] + np.float32(c[1]) * cell[1],
                   origin[2] + np.float32(c[2]) * cell[2])
            size = (cell[0] / np.float32(dims[0]), cell[1] / np.float32(dims[1]),
                    cell[2] / np.float32(dims[2]))
            x = (o[0] + d[0] * s_in, o[1] + d[1] * s_in, o[2] + d[2] * s_in)
            c = _cell_at(x, box, size, dims)
            continue
        if _leaf(tris, static, dynamic, leaf, ray, light, method, ray_id, big, st, cnt, count):
            return True
        nxt = _cell_exit(box, size, c, o, inv, step)
        a = (0 if nxt[0] < nxt[2] else 2) if nxt[0] < nxt[1] else (1 if nxt[1] < nxt[2] else 2)
        if nxt[a] > s1:
            return False
        s_in = nxt[a]
        c = _with(c, a, c[a] + step[a])
        if c[a] < 0 or c[a] >= dims[a]:
            if not inside:
                return False
            # Out of the sub-grid is out of its top cell, through the same face.
            inside, dims, box, size, first = False, gdims, origin, cell, 0
            c = _with(top, a, top[a] + step[a])
            if c[a] < 0 or c[a] >= dims[a]:
                return False


@njit(inline="always", **JIT)
def brute_walk(tris, n_tris, ray, cnt, count):
    """Every triangle, four per step as the shader counts them."""
    o, k, shear = ray
    for tri in range(0, n_tris, 4):
        m = min(4, n_tris - tri)
        if count:
            cnt[RT] += m
            cnt[BT] += m * TRIANGLE_BYTES
        for j in range(m):
            if ray_hits(tris, tri + j, o, k, shear):
                return True
    return False


# ---- points and samples (trace.comp main and sampled_walk) -------------------------------------
@njit(**JIT)
def _point(scene, p, nrm, t_row, method, ray_id, st, cnt, count):
    """Visible samples and rays traced (above the horizon) of one shaded point."""
    tris, static, dynamic, n_tris, grid, a, b, offsets, big = scene
    nrm = (nrm[0], nrm[1], nrm[2])
    r = F1 / np.sqrt(_dot(nrm, nrm))
    nrm = (nrm[0] * r, nrm[1] * r, nrm[2] * r)
    p = (p[0], p[1], p[2])
    off = offsets[0] + offsets[1] * _length(p)
    o = (p[0] + nrm[0] * off, p[1] + nrm[1] * off, p[2] + nrm[2] * off)
    light = (o, a, b)
    ba = _sub(b, a)
    key, used, mailbox, box = st[3], st[7], st[0], st[1]
    for i in range(len(key)):
        key[i] = 0  # the voxel cache, empty for each point
    used[0] = 0
    visible = 0
    rays = 0
    for i in range(len(t_row)):
        t = t_row[i]
        d = _sub((a[0] + t * ba[0], a[1] + t * ba[1], a[2] + t * ba[2]), o)
        if _dot(d, nrm) <= F0:
            continue  # below the receiver's horizon: the receiver hides it
        rays += 1
        k, shear = make_ray(d)
        ray = (o, k, shear)
        for j in range(len(mailbox)):
            mailbox[j] = -1
        box[0] = 0
        if method == BRUTE:
            hit = brute_walk(tris, n_tris, ray, cnt, count)
        else:
            hit = grid_walk(tris, static, dynamic, grid, o, d, ray, light, method, ray_id, big,
                            st, cnt, count)
        if not hit:
            visible += 1
    return visible, rays


@njit(**JIT)
def _points(lo, hi, scene, pts, nrms, ids, t, method, sizes, words, visible, rays, cnt, count,
            row):
    """Points lo..hi, with ``row`` as their scratch: mailbox, its cursor, the voxel cache's
    keys, starts and counts, its pool and its fill."""
    m, slots, pool = sizes
    a, b, c, e = m + 1, m + 1 + slots, m + 1 + 2 * slots, m + 1 + 3 * slots
    st = (row[:m], row[m:a], words, row[a:b], row[b:c], row[c:e], row[e:e + pool],
          row[e + pool:e + pool + 1])
    for j in range(lo, hi):
        ray_id = np.uint32((1 + ids[j]) & 0x7FFFFFFF)
        visible[j], rays[j] = _point(scene, pts[j], nrms[j], t[j], method, ray_id, st, cnt[j],
                                     count)


@njit(**JIT)
def trace_strided(first, stride, chunk, scene, pts, nrms, ids, t, method, sizes, words, visible,
                  rays, cnt, count, scratch):
    """Chunks ``first``, ``first + stride``, ... of ``chunk`` points each, each chunk with its
    row of ``scratch``. One call (0, 1) traces every point on this thread; ``stride`` threads
    calling it with first = 0, 1, ... share the points (it releases the GIL)."""
    n = len(pts)
    for c in range(first, (n + chunk - 1) // chunk, stride):
        _points(c * chunk, min(n, (c + 1) * chunk), scene, pts, nrms, ids, t, method, sizes,
                words, visible, rays, cnt, count, scratch[c])
