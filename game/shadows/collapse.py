"""When a light's shadows collapse: shadow texels far wider on screen than its plan aimed for.

Per map of a frame's plan, the texel footprint on screen where the map's shadows are seen
nearest the camera: a texel's world size (a perspective map's at that point's distance from
the light) times the screen's pixels per metre at that depth. The receivers are the floors',
statics' and characters' bounding boxes; the nearest point is the least view depth over each
box clipped to the view frustum and to the map's region (its tile's prism, else its own
rectangle's, from its near plane on, since every receiver behind its casters reads it). A box
is a bound: a receiver is at least as far as its box.

A map collapses where its texels are :data:`COLLAPSE_FACTOR` times wider on screen than the
plan's target there: the clumped method's density target (``texels_per_metre``, or
``view_texels_per_pixel`` for view-sized clump maps; ``character_texels_per_pixel`` for its
character maps) and, for methods sized by resolution alone, one texel per pixel. A target finer
than a pixel counts as one pixel (:data:`MIN_TARGET_PIXELS`). One note per light then says how
wide the texels are, why, and what the collapsed maps hold. No GL: map records, the view's
matrices and boxes.
"""

from __future__ import annotations

import itertools
import weakref
from dataclasses import dataclass

import numpy as np

from game.scene.geometry import PackedGeometry
from game.shadows.fit import MapFit
from game.shadows.method import ShadowMethod, ViewSized
from game.shadows.plan import (
    KIND_CASCADE,
    KIND_CHARACTER,
    KIND_CLUMP,
    KIND_FALLBACK,
    MapRecord,
    layer_bytes,
)

# Misclassified pixels along a shadow edge grow with the texel's width on screen. Planners
# degrade in halvings of a map's side, and one halving short of the target (2x) is the
# ordinary cost of a tight budget; past two halvings the staircase along every edge is several
# pixels deep and the error several times what the target would give: the shadows are wrong.
COLLAPSE_FACTOR = 4.0
# Texels finer than a pixel cannot be told apart on screen: a plan aiming finer is judged
# against one pixel per texel, so a far view of a dense plan never counts as collapsed.
MIN_TARGET_PIXELS = 1.0
# The statics a note names before it only counts the rest.
NAMED_STATICS = 3
_CHUNK = 256  # polytopes clipped at once (memory: chunk x plane triples x 3 floats)


@dataclass(frozen=True)
class Receivers:
    """What shadows fall on: world boxes (min x, y, z, max x, y, z), one per object."""

    boxes: np.ndarray    # (n, 6)
    objects: np.ndarray  # (n,) global object index

    @classmethod
    def of(cls, geom: PackedGeometry, models: np.ndarray) -> Receivers:
        """The floors' and statics' boxes, and the characters' at their poses in ``models``
        (their bounding spheres' boxes)."""
        boxes, objects = fixed_boxes(geom)
        models = np.asarray(models, float).reshape(-1, 4, 4)[:geom.n_characters]
        if len(models):
            centres = models[:, :3, 3]
            r = np.asarray(geom.character_radius, float)[:len(models), None]
            boxes = np.concatenate([boxes, np.concatenate([centres - r, centres + r], axis=1)])
            objects = np.concatenate([objects, [geom.character_object(i)
                                                for i in range(len(models))]])
        return cls(boxes, objects.astype(int))


_FIXED: list = [None, None]  # the last geometry's fixed boxes: a weak reference, the boxes


def fixed_boxes(geom: PackedGeometry) -> tuple[np.ndarray, np.ndarray]:
    """The floors' and statics' boxes and objects, kept for the last geometry asked: a
    frame's notes are asked again and again, and a large scene's statics take a while."""
    if _FIXED[0] is not None and _FIXED[0]() is geom:
        return _FIXED[1]
    boxes, objects = [], []
    for o in range(geom.n_floors):
        points = geom.positions[geom.triangles[o].reshape(-1)]
        if len(points):
            boxes.append(np.concatenate([points.min(axis=0), points.max(axis=0)]))
            objects.append(o)
    for i, points in enumerate(geom.static_points):
        if len(points):
            boxes.append(np.concatenate([points.min(axis=0), points.max(axis=0)]))
            objects.append(geom.static_object(i))
    _FIXED[:] = [weakref.ref(geom), (np.asarray(boxes, float).reshape(-1, 6),
                                     np.asarray(objects, int))]
    return _FIXED[1]


@dataclass(frozen=True)
class MapTexels:
    """One map's texels on screen where its shadows are seen nearest the camera."""

    index: int          # into the plan's maps
    depth: float        # view depth of that point (inf: no receiver of it in view)
    pixels: float       # a texel's width there, in screen pixels
    target: float       # the plan's aim there, in pixels (at least MIN_TARGET_PIXELS)

    @property
    def collapsed(self) -> bool:
        return self.pixels > COLLAPSE_FACTOR * self.target


# -- geometry ---------------------------------------------------------------------------------
def clip_planes(m: np.ndarray, x: tuple[float, float] = (-1.0, 1.0),
                y: tuple[float, float] = (-1.0, 1.0), far: bool = True) -> np.ndarray:
    """The half-spaces (a, b, c, d), a.p + d >= 0 inside, of the volume that the world-to-clip
    matrix ``m`` maps into x and y (NDC ranges) and -1 <= z (<= 1 with ``far``)."""
    r0, r1, r2, r3 = m
    planes = [r0 - x[0] * r3, x[1] * r3 - r0, r1 - y[0] * r3, y[1] * r3 - r1, r2 + r3]
    if far:
        planes.append(r3 - r2)
    return np.array(planes, float)


def box_planes(boxes: np.ndarray) -> np.ndarray:
    """(n, 6, 4) half-spaces of axis-aligned boxes (n, 6)."""
    n = len(boxes)
    planes = np.zeros((n, 6, 4))
    for axis in range(3):
        planes[:, 2 * axis, axis] = 1.0
        planes[:, 2 * axis, 3] = -boxes[:, axis]
        planes[:, 2 * axis + 1, axis] = -1.0
        planes[:, 2 * axis + 1, 3] = boxes[:, 3 + axis]
    return planes


def nearest_vertices(planes: np.ndarray, depth_row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per polytope (n, k, 4) of half-spaces, the least ``depth_row . (p, 1)`` over its
    vertices, and that vertex; inf (and NaN) where it is empty.

    A linear function's least value over a bounded convex polytope is at a vertex, and every
    vertex is where three of its planes meet: each triple is solved and kept where every plane
    holds it."""
    n, k, _ = planes.shape
    norm = np.linalg.norm(planes[..., :3], axis=-1, keepdims=True)
    planes = planes / np.maximum(norm, 1e-300)
    triples = np.array(list(itertools.combinations(range(k), 3)))
    best = np.full(n, np.inf)
    where = np.full((n, 3), np.nan)
    for start in range(0, n, _CHUNK):
        p = planes[start:start + _CHUNK]
        a, b, c = (p[:, triples[:, j]] for j in range(3))   # (m, t, 4)
        bc, ca, ab = (np.cross(u[..., :3], v[..., :3]) for u, v in ((b, c), (c, a), (a, b)))
        det = np.einsum("mti,mti->mt", a[..., :3], bc)
        ok = np.abs(det) > 1e-9
        point = -(a[..., 3:] * bc + b[..., 3:] * ca + c[..., 3:] * ab) / np.where(
            ok, det, 1.0)[..., None]
        inside = np.einsum("mki,mti->mtk", p[..., :3], point) + p[:, None, :, 3]
        scale = 1.0 + np.abs(point).max(axis=-1)
        ok &= (inside >= -1e-7 * scale[..., None]).all(axis=-1)
        depth = np.where(ok, point @ depth_row[:3] + depth_row[3], np.inf)
        pick = depth.argmin(axis=1)
        rows = np.arange(len(p))
        best[start:start + len(p)] = depth[rows, pick]
        where[start:start + len(p)] = np.where(np.isfinite(depth[rows, pick])[:, None],
                                               point[rows, pick], np.nan)
    return best, where


def pixels_per_metre(view, depth: float) -> float:
    """Screen pixels per metre across the view at view depth ``depth``."""
    proj, height = view.proj, view.size[1]
    if proj[3, 3] == 1.0:  # orthographic: the same at every depth
        return 0.5 * height * proj[1, 1]
    return 0.5 * height * proj[1, 1] / max(depth, 1e-9)


def region_planes(record: MapRecord) -> np.ndarray:
    """The half-spaces of the part of the world whose fragments read ``record``: its tile's
    prism (or its own rectangle's) from its near plane on."""
    m = record.fit.view_proj
    if record.tile is None or record.fit.perspective:
        return clip_planes(m, far=False)
    x0, y0, x1, y1 = record.fit.rect
    tx0, ty0, tx1, ty1 = record.tile
    return clip_planes(m, (2 * (tx0 - x0) / (x1 - x0) - 1, 2 * (tx1 - x0) / (x1 - x0) - 1),
                       (2 * (ty0 - y0) / (y1 - y0) - 1, 2 * (ty1 - y0) / (y1 - y0) - 1),
                       far=False)


def overlapping(record: MapRecord, boxes: np.ndarray) -> np.ndarray:
    """(n,) whether each box may reach the map's region (conservative where a corner lies
    behind a perspective map's eye)."""
    corners = np.stack([boxes[:, [x, y, z]] for x in (0, 3) for y in (1, 4) for z in (2, 5)],
                       axis=1)
    clip = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=-1)
    clip = clip @ record.fit.view_proj.T
    w = clip[..., 3]
    behind = (w <= 1e-9).any(axis=1)
    ndc = clip[..., :3] / np.where(w > 1e-9, w, 1.0)[..., None]
    lo, hi = ndc.min(axis=1), ndc.max(axis=1)
    x, y = (-1.0, 1.0), (-1.0, 1.0)
    if record.tile is not None and not record.fit.perspective:
        x0, y0, x1, y1 = record.fit.rect
        t = record.tile
        x = (2 * (t[0] - x0) / (x1 - x0) - 1, 2 * (t[2] - x0) / (x1 - x0) - 1)
        y = (2 * (t[1] - y0) / (y1 - y0) - 1, 2 * (t[3] - y0) / (y1 - y0) - 1)
    hit = (lo[:, 0] <= x[1]) & (hi[:, 0] >= x[0]) & (lo[:, 1] <= y[1]) & (hi[:, 1] >= y[0])
    return behind | (hit & (hi[:, 2] >= -1.0))


def _cutting(planes: np.ndarray, box: np.ndarray) -> np.ndarray:
    """The half-spaces of ``planes`` (k, 4) that cut the box (6,): a half-space that holds all
    of the box's corners holds all of its part that the others keep, so it changes nothing, and
    the vertices to try grow with the cube of the planes."""
    corners = np.array([[box[x], box[y], box[z], 1.0] for x in (0, 3) for y in (1, 4)
                        for z in (2, 5)])
    return planes[(corners @ planes.T < 0.0).any(axis=0)]


class ViewDepths:
    """The receivers' least view depths within the view frustum, then per map within its
    region: each box is clipped to a map's region only while it could still be the nearest."""

    def __init__(self, receivers: Receivers, view):
        self.receivers = receivers
        self.view = view
        self.frustum = clip_planes(view.proj @ view.view)
        self.depth_row = -np.asarray(view.view[2], float)
        boxes = receivers.boxes
        self.depths = np.full(len(boxes), np.inf)
        if not len(boxes):
            return
        corners = np.stack([boxes[:, [x, y, z]] for x in (0, 3) for y in (1, 4)
                            for z in (2, 5)], axis=1)
        hom = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=-1)
        side = hom @ self.frustum.T                       # (n, 8, 6)
        outside = (side < 0).all(axis=1).any(axis=1)      # all corners beyond one plane
        inside = (side >= 0).all(axis=(1, 2))             # every corner in view
        self.depths[inside] = (hom[inside] @ self.depth_row).min(axis=1)
        cut = np.flatnonzero(~inside & ~outside)
        if len(cut):
            planes = np.concatenate([box_planes(boxes[cut]),
                                     np.broadcast_to(self.frustum, (len(cut), 6, 4))], axis=1)
            self.depths[cut] = nearest_vertices(planes, self.depth_row)[0]

    def nearest(self, record: MapRecord) -> tuple[float, np.ndarray | None]:
        """The least view depth of a receiver in view within ``record``'s region, and where."""
        visible = np.flatnonzero(np.isfinite(self.depths))
        if not len(visible):
            return np.inf, None
        visible = visible[overlapping(record, self.receivers.boxes[visible])]
        region = region_planes(record)
        best, point = np.inf, None
        bounds = np.concatenate([self.frustum, region])
        for r in visible[np.argsort(self.depths[visible], kind="stable")]:
            if self.depths[r] >= best:
                break
            box = self.receivers.boxes[r]
            planes = np.concatenate([box_planes(box[None])[0], _cutting(bounds, box)])[None]
            depth, where = nearest_vertices(planes, self.depth_row)
            if depth[0] < best:
                best, point = float(depth[0]), where[0]
        return best, point


# -- targets and notes ------------------------------------------------------------------------
def target_pixels(method: ShadowMethod, record: MapRecord, per_metre: float) -> float:
    """What the plan aimed for, in screen pixels per texel, where ``per_metre`` pixels span a
    metre; at least :data:`MIN_TARGET_PIXELS`."""
    s = method.settings
    aim = MIN_TARGET_PIXELS
    if isinstance(method, ViewSized):  # the clumped method's density targets
        if record.kind == KIND_CLUMP:
            aim = (1.0 / s.view_texels_per_pixel if s.view_resolution
                   else per_metre / s.texels_per_metre)
        elif record.kind == KIND_CHARACTER and s.character_texels_per_pixel > 0:
            aim = 1.0 / s.character_texels_per_pixel
    return max(aim, MIN_TARGET_PIXELS)


def map_texels(method: ShadowMethod, maps: list[MapRecord], first: int,
               depths: ViewDepths) -> list[MapTexels]:
    """Each of a light's ``maps`` (the plan's ``first`` on) on screen; of cascades only the
    finest read at the nearest receivers, since the shader reads the first cascade whose
    rectangle holds a fragment."""
    out = []
    for k, record in enumerate(maps):
        if record.kind == KIND_FALLBACK:
            # Read only where no clump map holds a fragment: the receivers nearest the camera
            # in its rectangle are mostly the clump maps', which are judged instead.
            continue
        depth, point = depths.nearest(record)
        if not np.isfinite(depth):
            continue
        texel = record.fit.texel
        if record.fit.perspective:  # metres per texel per metre from the light
            texel *= float(record.fit.view_proj[3] @ np.append(point, 1.0))
        per_metre = pixels_per_metre(depths.view, depth)
        out.append(MapTexels(first + k, depth, texel * per_metre,
                             target_pixels(method, record, per_metre)))
    cascades = [t for t in out if maps[t.index - first].kind == KIND_CASCADE]
    if cascades:
        nearest = min(t.depth for t in cascades)
        finest = next(t for t in cascades if t.depth <= nearest * (1 + 1e-6))
        out = [t for t in out if t is finest or t not in cascades]
    return out


def _cause(method: ShadowMethod) -> str:
    """Why the light's maps are no finer: the limit that binds a budgeted method's layers, or
    a baseline's resolution."""
    s, res = method.settings, method.resolution
    if not method.budgeted:
        return f"its maps have {res}^2 texels whatever the view"
    budget_layers = int(s.budget_mib * 2**20 // layer_bytes(res))
    layers = "layer" if budget_layers == 1 else "layers"
    limits = [(budget_layers, f"its {s.budget_mib:.3g} MiB of the shadow budget hold "
                              f"{budget_layers} {layers} of {res}^2"),
              (method.max_layers, f"the GL's {method.max_layers} array layers"),
              (method.max_maps, f"the {method.max_maps} map records the shading pass holds")]
    return min(limits, key=lambda item: item[0])[1]


def _affected(geom: PackedGeometry, maps: list[MapRecord], collapsed: list[MapTexels],
              first: int) -> str:
    """What the collapsed maps hold: how many maps, statics (the first few named) and
    walkers."""
    objects = sorted({o for t in collapsed for o in maps[t.index - first].objects})
    statics = [o for o in objects if geom.first_static <= o < geom.first_character]
    walkers = [o for o in objects if o >= geom.first_character]
    parts = [f"{len(collapsed)} of {len(maps)} maps"]
    if statics:
        names = ", ".join(geom.names[o] for o in statics[:NAMED_STATICS])
        more = ", ..." if len(statics) > NAMED_STATICS else ""
        parts.append(f"{len(statics)} of {geom.n_statics} statics ({names}{more})")
    if walkers:
        parts.append(f"{len(walkers)} of {geom.n_characters} walkers")
    return ", ".join(parts)


def coarse_statics_note(method: ShadowMethod, fits: list[MapFit]) -> str | None:
    """A baseline's note where its map of a directional light's statics holds fewer than one
    :data:`COLLAPSE_FACTOR`-th of clumped's target texels per metre, or None. Seen
    from far away those texels may be under a pixel wide on screen, no collapse; their bias
    still moves every shadow's edge by about a texel and loses the shadows of details under it
    (a town's window recesses)."""
    if not fits or fits[0].perspective:
        return None
    density = 1.0 / max(f.texel for f in fits)
    target = method.settings.texels_per_metre
    if density * COLLAPSE_FACTOR >= target:
        return None
    return (f"its {method.resolution}^2 map holds {density:.3g} texels/m over the statics, "
            f"where clumped aims for {target:g}: texels {100.0 / density:.0f} cm wide move "
            f"every shadow's edge and lose the shadows of details under them")


def light_note(k: int, method: ShadowMethod, maps: list[MapRecord], first: int,
               depths: ViewDepths, geom: PackedGeometry) -> str | None:
    """The one note on light ``k`` whose maps collapsed in this view, or None."""
    texels = map_texels(method, maps, first, depths)
    collapsed = [t for t in texels if t.collapsed]
    if not collapsed:
        return None
    worst = max(collapsed, key=lambda t: t.pixels / t.target)
    return (f"light {k}: {method.name}: {_cause(method)}, so shadow texels are "
            f"{worst.pixels:.1f} screen pixels wide near the camera (target {worst.target:.2g},"
            f" collapsed past {COLLAPSE_FACTOR:g}x): accuracy collapses on "
            f"{_affected(geom, maps, collapsed, first)}")


def collapse_notes(methods: list[ShadowMethod], maps: list[MapRecord], first_maps: list[int],
                   view, geom: PackedGeometry, models: np.ndarray) -> list[str]:
    """One note per light whose maps collapsed in ``view``, and one per light whose method
    says its scheme loses in this view (:meth:`ShadowMethod.view_note`): ``maps`` are the
    frame's plan's, light k's from ``first_maps[k]`` to the next light's first."""
    if view is None or view.size is None or not maps:
        return []
    depths = ViewDepths(Receivers.of(geom, models), view)
    nearest = float(depths.depths.min()) if len(depths.depths) else np.inf
    ends = list(first_maps[1:]) + [len(maps)]
    notes = []
    for k, (method, start, end) in enumerate(zip(methods, first_maps, ends, strict=True)):
        note = light_note(k, method, maps[start:end], start, depths, geom)
        if note is not None:
            notes.append(note)
        note = method.view_note(view, maps[start:end], nearest)
        if note is not None:
            notes.append(f"light {k}: {note}")
    return notes
