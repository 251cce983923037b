"""``clumped``: the multi-map method of "Some Ideas on Shadow Algorithms".

One cached map per clump of statics and tight character maps re-rendered every frame (sized for
the view, skipped, grouped and packed by game/shadows/crowd.py), all in one depth texture array.
Floors are never drawn into any map.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np

from game import transforms
from game.scene import Light
from game.scene.geometry import PackedGeometry
from game.shadows import clumping, crowd
from game.shadows.atlas import Square
from game.shadows.fit import (
    CUBE_FACES,
    MAX_TAN,
    MapFit,
    cube_face_reach,
    fit_cube_faces,
    fit_directional,
    fit_perspective,
    fit_squares,
    holds_in_one_frustum,
    light_rotation_of,
    outside_cone,
)
from game.shadows.map_grid import octahedral_encode
from game.shadows.method import ShadowMethod, bounding_sphere
from game.shadows.plan import (
    CHARACTER_DENSITY_FLOOR,
    KIND_CHARACTER,
    KIND_CLUMP,
    KIND_FALLBACK,
    MIN_CLUMP_RESOLUTION,
    MIN_SHORT_RESOLUTION,
    MapRecord,
    ShadowPlan,
    ShadowSettings,
    layer_bytes,
)
from game.shadows.view_budget import ClumpRequest, Placement, ViewBudget, atlas_shape

# A clump around a point light gets one frustum only when it is no wider than a cube face (45
# degrees either side of its axis): a wider one spreads its texels thinner than the faces do.
CUBE_FACE_TAN = 1.0

# View-sized maps: the share of a map's weight that its counts before the last frame keep.
EDGE_MEMORY = 0.5

# The clump maps' keys for the view's budget: numbers never given twice in a run, so that no two
# maps, of any light or planner, share one (_index_view_maps).
_MAP_IDS = itertools.count()


def _footprint(light: Light, statics: list[np.ndarray]):
    """Light-space footprint function and units-per-metre scale for clumping."""
    if light.kind == "directional":
        return clumping.directional_footprint(transforms.light_rotation(light.direction)), 1.0
    eye = np.asarray(light.position, float)
    distances = [np.linalg.norm(p.mean(axis=0) - eye) for p in statics] or [1.0]
    typical = max(float(np.median(distances)), 1e-6)
    if light.kind == "spot":
        view = transforms.look_at(eye, eye + light.direction)

        def spot(points: np.ndarray) -> np.ndarray:
            v = transforms.transform_points(view, points)
            depth = np.maximum(-v[:, 2], 1e-6 * typical)
            return v[:, :2] / depth[:, None]

        return spot, 1.0 / typical

    def point(points: np.ndarray) -> np.ndarray:
        return octahedral_encode(np.asarray(points, float) - eye)

    # An octahedral unit spans about pi/2 radians.
    return point, 1.0 / (typical * math.pi / 2)


def _box_corners(points: np.ndarray) -> np.ndarray:
    """The 8 corners of the axis-aligned box of ``points``."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                     for i in (0, 1) for j in (0, 1) for k in (0, 1)])


class ClumpedShadows(ShadowMethod):
    """The multi-map method: cached clump maps plus per-character maps in one array.

    The number of clumps follows the texel-density target, within the layers that the memory
    budget and the GL limits allow; when the target needs more, the clumps grow (and their
    texel density falls) and ``notes`` says so. The character maps share a few layers, packed
    anew each frame; when the layers or the map records run short, maps get coarser or are
    merged (degrade, never drop a shadow).

    Layers are handed out from a pool: a clump keeps its layers while it exists, a removed one
    gives them back, and a new one takes the lowest free layer, so the array only grows when
    every layer is in use. Clumps are kept by member
    name, so a static added, removed or moved at run time (:meth:`update_statics`) re-renders
    only the clump maps it leaves or joins.
    """

    name = "clumped"
    summary = ("one cached map per clump of statics and tight character maps sized for the view, "
               "in one depth array")
    resolution_fields = ("clump_resolution", "character_resolution")
    parameters = ("clumping", "clump_count", "texels_per_metre", "clump_resolution",
                  "character_resolution", "character_texels_per_pixel", "view_resolution",
                  "max_clump_resolution")
    budgeted = True
    shares_view_budget = True

    @classmethod
    def min_layers(cls, settings: ShadowSettings, n_characters: int) -> int:
        return 1 + min(n_characters, 1)  # one clump and one (shared) character map

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int, max_maps: int | None = None):
        if settings.view_resolution:
            # The atlas's squares have power-of-two sides: the fixed maps whose texels it holds
            # too, no larger than asked, so that it keeps to the budget.
            side = settings.clump_resolution
            settings = dataclasses.replace(settings, clump_resolution=1 << (side.bit_length() - 1))
        super().__init__(geom, light, settings, max_layers, max_maps)
        self._start(settings)
        side = settings.clump_resolution
        if self._short and settings.clump_count is None and side // 2 >= MIN_SHORT_RESOLUTION:
            # Short of layers, maps of a quarter of the texels, four times as many, hug the
            # statics closer and leave less of the budget on empty ground between them.
            self.notes = []
            self._start(dataclasses.replace(settings, clump_resolution=side // 2))
            self.note(f"the clumps at {settings.texels_per_metre:g} texels/m do not fit the "
                      f"{settings.budget_mib:g} MiB budget in maps of {side}^2: the clump "
                      f"maps are {side // 2}^2, four times as many")

    def _start(self, settings: ShadowSettings) -> None:
        """Everything planned from the settings: layers, clumps, character maps."""
        self.settings = settings
        self._budget_layers = int(settings.budget_mib * 2**20 // layer_bytes(
            settings.clump_resolution))
        self.layer_limit = max(2, min(self._budget_layers, self.max_layers))
        self.static_maps: list[MapRecord] = []
        self.clumps: list[clumping.Clump] = []
        self._clump_keys: list[list[tuple[str, int]]] = []  # member units' keys per clump
        self._clump_layers: list[list[int]] = []  # a clump's layers: one, or cube faces
        self._dirty: set[int] = set()             # clumps (indices) whose maps must be drawn
        self._free: list[int] = []                # layers given back, reused lowest first
        self._high = 0                            # layers ever handed out
        self._char_layers: list[int] = []         # the layers the character maps share
        self._char_boxes: np.ndarray | None = None  # (n, 8, 3) local bounding-box corners
        self._names: list[str] | None = None        # the characters' names, for the crowd
        # Parts are split for maps this many times wider than the density target's (above 1
        # where the budget cannot meet the target) and whether it cannot (_build_static).
        self._extent_scale = 1.0
        self._short = False
        self.crowd = crowd.CrowdPlanner(
            min(settings.min_character_resolution, self._character_resolution),
            self._character_resolution)
        self._assign_characters()
        self.view_budget: ViewBudget | None = None
        self._shared_side: int | None = None  # the lights' shared atlas's side, when shared
        self._given = None                     # this frame's placements in it
        self._reserved_squares: list[Square] | None = None
        # Per clump map's key, the length of its shadow edges on screen in widths of the map,
        # from the counted frames (:meth:`served`); the needs of the last view's requests; the
        # last plan's clump maps: key, record, side and need.
        self._edge_widths: dict = {}
        self._asked: np.ndarray | None = None
        self._planned: list[tuple] = []
        self._map_ids: dict[tuple, int] = {}  # the clump maps' keys (_index_view_maps)
        self._placed_records: dict[int, tuple] = {}  # _placed's last records, by index
        self.set_light(self.light)

    # -- layers ---------------------------------------------------------------------------
    def _take_layer(self) -> int:
        if self._free:
            self._free.sort()
            return self._free.pop(0)
        self._high += 1
        return self._high - 1

    def _give_layer(self, layer: int) -> None:
        self._free.append(layer)

    @property
    def reserved_layers(self) -> int:
        # A light moved or edited may clump anew into more or fewer layers, up to the limit.
        if self.view_budget is not None:
            return self.layers
        return max(self.layers, self.layer_limit)

    @property
    def wants_memory(self) -> bool:
        # Short of the budget's layers, not the GL's, and without room for one more clump's
        # maps: a lamp whose clumps all surround it ends in one cube, whatever it is given.
        one_more = CUBE_FACES if self.light.kind == "point" else 1
        return (self._short and self._budget_layers < self.max_layers
                and self._fixed_layers + one_more > self.layer_limit)

    @property
    def memory_mib(self) -> float:
        # The fixed maps' layers: view-sized maps take as many texels.
        return self._fixed_layers * layer_bytes(self.settings.clump_resolution) / 2**20

    def limit_memory(self, mib: float) -> None:
        super().limit_memory(mib)
        self._budget_layers = int(mib * 2**20 // layer_bytes(self.settings.clump_resolution))
        self.layer_limit = max(2, min(self._budget_layers, self.max_layers, self.layer_limit))

    @property
    def max_clumps(self) -> int:
        return max(1, self.layer_limit - len(self._char_layers))

    @property
    def layers(self) -> int:
        if self.view_budget is not None:
            return self.view_budget.atlas.layers
        return self._fixed_layers

    @property
    def _fixed_layers(self) -> int:
        """The layers of ``clump_resolution`` that the clump and character maps take."""
        return max(1, self._high)

    @property
    def resolution(self) -> int:
        if self._shared_side is not None:
            return self._shared_side
        if self.view_budget is not None:
            return self.view_budget.atlas.resolution
        return self.settings.clump_resolution

    def _make_view_budget(self) -> None:
        """With ``view_resolution``, the squares the clump maps take by need
        (game/shadows/view_budget.py), in as many texels as the fixed maps would take (their
        layers, the characters' among them); the character maps keep squares of their own.
        A light among others has none of its own: the lights share one
        (:meth:`share_view_budget`)."""
        s = self.settings
        if not s.view_resolution or self._shared_side is not None:
            return
        texels = (len(self.static_maps) + len(self._char_layers)) * s.clump_resolution ** 2
        layers, side = atlas_shape(texels, s.clump_resolution, s.max_clump_resolution)
        if self.view_budget is not None:
            if (self.view_budget.atlas.layers, self.view_budget.atlas.resolution) == (layers,
                                                                                       side):
                return
            self._dirty = set(range(len(self._clump_keys)))  # every map is placed anew
        self.view_budget = ViewBudget(layers, side, min(MIN_CLUMP_RESOLUTION, s.clump_resolution),
                                      self.reserved_sides, s.max_map_renders)

    # -- view-sized maps in the lights' shared atlas ------------------------------------------
    @property
    def reserved_sides(self) -> list[int]:
        """The sides of the squares the character maps keep in a view-sized atlas."""
        return [self.settings.clump_resolution] * len(self._char_layers)

    @property
    def fixed_texels(self) -> int:
        """The texels this light's fixed maps keep in the array: its limit's layers."""
        return max(self._fixed_layers, self.layer_limit) * self.settings.clump_resolution ** 2

    def share_view_budget(self, side: int) -> None:
        """Place the clump maps in an atlas of ``side``-texel layers that the lights share
        (game/shadows/lights.py), which hands each frame's placements to :meth:`place_by_view`
        before :meth:`plan`; the light keeps no atlas of its own."""
        self._shared_side = side
        self.view_budget = None
        self._dirty = set(range(len(self._clump_keys)))

    def _index_view_maps(self) -> None:
        """What the view's budget asks of each clump map that does not depend on the view,
        kept while the clumps are: its record, its clump, its key, the centre and width it
        is measured at (a clump's bounding sphere, a cube face's :func:`cube_face_reach`), and
        the clumps' spheres for their shadow volumes."""
        owners, centres, widths, keys, records, within = [], [], [], [], [], []
        ids: dict[tuple, int] = {}
        for k, members in enumerate(self._clump_keys):
            centre, radius = self._clump_spheres[k]
            faces = self._face_reach.get(k)
            own = tuple(members)
            count = len(self._map_of_clump.get(k, []))
            for j, i in enumerate(self._map_of_clump.get(k, [])):
                # A map's key is a number that stays while its clump's members do: the budget
                # hashes keys many times a frame, and a tuple of the members is slow to hash.
                ident = self._map_ids.get((own, count, j))
                ids[own, count, j] = ident if ident is not None else next(_MAP_IDS)
                owners.append(k)
                records.append(i)
                keys.append(ids[own, count, j])
                within.append(j)
                centres.append(faces[j][0] if faces else centre)
                widths.append(faces[j][1] if faces else 2.0 * radius)
        self._map_ids = ids
        spheres = [self._clump_spheres[k] for k in range(len(self._clump_keys))]
        self._view_maps = {
            "owners": np.array(owners, int), "records": records, "keys": keys,
            "within": within,
            "centres": np.array(centres, float).reshape(-1, 3), "widths": np.array(widths, float),
            "sphere_centres": np.array([c for c, _ in spheres], float).reshape(-1, 3),
            "sphere_radii": np.array([r for _, r in spheres], float)}

    @property
    def counts_pixels(self) -> bool:
        return self.view_budget is not None or self._shared_side is not None

    @property
    def placed_blind(self) -> bool:
        """Whether its own view-sized atlas placed every map of the last plan anew with no
        pixels counted (the first frame): :meth:`place_anew` once they are."""
        return self.view_budget is not None and self.view_budget.blind

    def place_anew(self) -> None:
        """Every view-sized map placed (and drawn) anew on the next plan."""
        if self.view_budget is not None:
            self.view_budget.forget()

    def served(self, pixels: np.ndarray) -> None:
        """The length of each clump map's shadow edges in widths of the map, kept by map key
        for the next frames' weights. At the side s it had, a texel spans need / s /
        ``view_texels_per_pixel`` pixels, so that many pixels were counted per pixel of edge;
        the edges' length over the map's width in pixels (the need over the texels per pixel)
        is then the count times s times the texels per pixel squared over the need squared.
        It changes little as the camera comes nearer or goes away, or the frame is resized,
        where the count itself goes with the need. Half of it is kept from the frames before:
        one frame's count moves with every step of the camera and every walker, and maps sized
        by it alone changed side, and were drawn again, several a frame while the camera
        turned by a degree a frame."""
        last, tpp = self._edge_widths, self.settings.view_texels_per_pixel
        widths = {}
        for key, record, side, need in self._planned:
            if need <= 0:  # not in view: nothing was counted
                if key in last:
                    widths[key] = last[key]
                continue
            # One pixel more than counted: a count of a few pixels is mostly chance, and a
            # map that shows none at one side and a few at the next would change side each
            # frame.
            counted = (int(pixels[record]) + 1.0) * side * tpp ** 2 / need ** 2
            widths[key] = (EDGE_MEMORY * last[key] + (1 - EDGE_MEMORY) * counted
                           if key in last else counted)
        self._edge_widths = widths

    def view_requests(self, view) -> tuple[list[ClumpRequest], set[int]]:
        """Each clump map as the view's budget sees it, clump by clump, and those that must be
        drawn whatever their side (their clump changed). A map's need is the texels that give
        ``view_texels_per_pixel`` across its width (:meth:`_index_view_maps`) where the
        clump's shadow is seen, none where the view cannot see it. Its weight
        (game/shadows/view_budget.py) is its need squared times the length of its shadow
        edges in widths of the map, as counted (:meth:`served`); a map not counted yet has
        edges one width long."""
        s, light, m = self.settings, self.light, self._view_maps
        owners, width = m["owners"], m["widths"]
        n = len(owners)
        need = np.ones(n)  # without a view, alike: the budget's scale sets them
        weight = None
        if view is not None and view.size is not None and n:
            eye = None if light.kind == "directional" else np.asarray(light.position, float)
            volumes, bounded = crowd.shadow_volumes(m["sphere_centres"], m["sphere_radii"],
                                                    light.kind, light.direction, eye,
                                                    self._ground)
            hidden = (bounded & crowd.outside_view(volumes, view.proj @ view.view))[owners]
            # The density the map's shadow needs where most of it is seen: at its centre's
            # distance (at least half its width), not at its nearest point, which for a clump
            # beside the camera would ask the most texels for a sliver of its shadow.
            depth = np.maximum(-(m["centres"] @ view.view[2, :3] + view.view[2, 3]),
                               np.maximum(width / 2, 1e-6))
            need = width * 0.5 * view.size[1] * view.proj[1, 1] / depth * s.view_texels_per_pixel
            need[hidden] = 0.0
            if self._edge_widths:
                edges = np.array([self._edge_widths.get(key, 1.0) for key in m["keys"]])
                weight = need ** 2 * edges
        self._asked = need
        requests = [ClumpRequest(key=key, maps=1, need=float(need[q]),
                                 weight=None if weight is None else float(weight[q]),
                                 refit=lambda side, k=int(owners[q]), j=m["within"][q]:
                                 self._fits_at(k, side)[j:j + 1])
                    for q, key in enumerate(m["keys"])]
        must = {q for q in range(n) if owners[q] in self._dirty}
        return requests, must

    def place_by_view(self, placements: list[Placement], drawn: set[int],
                      reserved: list[Square]) -> None:
        """This frame's placements from the shared atlas: every clump map's (in the order of
        :meth:`view_requests`), those drawn, and the character maps' squares."""
        self._given = (placements, drawn, reserved)

    def _character_names(self) -> list[str]:
        g = self.geom
        return [g.names[g.character_object(i)] for i in range(g.n_characters)]

    @property
    def _character_resolution(self) -> int:
        return min(self.settings.character_resolution, self.settings.clump_resolution)

    def _assign_characters(self) -> None:
        """Hold enough layers for every character's map at the largest size (the maps are
        packed into them anew each frame, game/shadows/crowd.py), as far as the clumps leave
        room and at most half the layers; fewer layers make the frame's largest maps coarser,
        never drop one. The half keeps the cached clump maps, where the method's accuracy
        comes from, from being starved by a worst case that maps sized by need rarely reach."""
        n = self.geom.n_characters
        square = crowd.layer_square(self.settings.clump_resolution)
        per_layer = max(1, (square // crowd.pow2_at_least(self._character_resolution)) ** 2)
        want = -(-n // per_layer)
        if want > self.layer_limit // 2:
            note = (f"{n} characters' maps at {self._character_resolution}^2 need {want} "
                    f"shadow-map layers; they get {max(1, self.layer_limit // 2)}, half the "
                    "budget's: the largest maps of a frame are made coarser when they do not fit")
            self.note(note)
            want = max(1, self.layer_limit // 2)
        if self.light.range is not None:
            # A lamp reaches few characters at once: one shared layer, the maps made smaller
            # when more come (crowd.pack), leaves the rest to its clumps' maps.
            want = min(want, 1)
        room = self.layer_limit - max(1, sum(len(ls) for ls in self._clump_layers))
        count = min(want, max(room, 1)) if n else 0
        while len(self._char_layers) > count:
            self._give_layer(self._char_layers.pop())
        while len(self._char_layers) < count:
            self._char_layers.append(self._take_layer())
        if count < want:
            note = (f"{n} characters' maps at {self._character_resolution}^2 need {want} "
                    f"shadow-map layers, {count} are free (GL or memory limit): the largest "
                    "maps of a frame are made coarser when they do not fit")
            self.note(note)

    # -- statics ----------------------------------------------------------------------------
    def set_light(self, light: Light) -> None:
        """A new light invalidates every clump map (and light-space clumps themselves)."""
        self.light = light
        self._light_rot = light_rotation_of(light)
        self._ground = self._ground_height()
        self._build_static()

    def _ground_height(self) -> float:
        """The lowest height of the floors and statics: no shadow falls below it."""
        g = self.geom
        fixed = g.objects < g.first_character
        return float(g.positions[fixed, 1].min()) if fixed.any() else math.inf

    def _fit(self, points: np.ndarray, resolution: int, radius: float | None = None
             ) -> MapFit | None:
        light = self.light
        if light.kind == "directional":
            return fit_directional(points, self._light_rot, resolution, radius)
        if light.kind == "spot" and outside_cone(points, light.position, light.direction,
                                                 light.cone):
            return None
        return fit_perspective(points, light.position, resolution)

    def _static_names(self) -> list[str]:
        g = self.geom
        return [g.names[g.static_object(i)] for i in range(g.n_statics)]

    def _max_extent(self, per_metre: float) -> float:
        s = self.settings
        return (clumping.max_extent_for_density(s.clump_resolution, s.texels_per_metre)
                * per_metre * self._extent_scale)

    def _make_units(self) -> None:
        """The statics' parts (game/scene/parts.py), a part wider than one map at the density
        target split further (:func:`clumping.split_wide`): what the clumps are made of.
        Each unit has a key, (static name, serial), stable while its static is unchanged."""
        g = self.geom
        names = self._static_names()
        # The faces beyond the light's range are in no clump, but the index buffer's order
        # (static_pieces) must still hold every face.
        reached = set(self.reached_statics())
        self._beyond = [(i, np.arange(len(g.triangles[g.static_object(i)])))
                        for i in range(g.n_statics) if i not in reached]
        parts: list[tuple[int, np.ndarray]] = []
        points: list[np.ndarray] = []
        for i in sorted(reached):
            labels = g.static_parts[i]
            order = np.argsort(labels, kind="stable")
            split = np.split(order, np.flatnonzero(np.diff(labels[order])) + 1)
            for faces in split:
                parts.append((i, faces))
                points.append(g.static_points[i] if len(split) == 1
                              else g.static_corners(i, faces))
        footprint, per_metre = _footprint(self.light, points)
        limit = self._max_extent(per_metre)
        rects = clumping.object_summaries(points, footprint)[0] if points else np.zeros((0, 4))
        self._units, self._unit_points, self._unit_keys = [], [], []
        serial = dict.fromkeys(range(g.n_statics), 0)
        ranged = self.light.range is not None
        for (i, faces), part_points, rect in zip(parts, points, rects, strict=True):
            pieces = [faces]
            if clumping.rect_extent(rect) > limit and len(faces) > 1:
                corners = g.static_corners(i, faces).reshape(-1, 3, 3)
                pieces = clumping.split_wide(corners, faces, footprint, limit)
            for piece in pieces:
                unit_points = part_points if len(pieces) == 1 else g.static_corners(i, piece)
                if ranged and not self.light.reaches(*bounding_sphere(unit_points)):
                    self._beyond.append((i, piece))  # a part of a large static out of range
                    continue
                self._units.append((i, piece))
                self._unit_points.append(unit_points)
                self._unit_keys.append((names[i], serial[i]))
                serial[i] += 1
        # A single face wider than one map at the target (a roof's edge, a long wall's side)
        # cannot be split. Clumped alone it would take a coarse map of its own and spread every
        # map it joined; instead it is drawn into each clump map it crosses, at that map's
        # texels, and owned by a few coarse maps of such faces for the ground between clumps
        # (directional lights, where a map's footprint is a rectangle of the common plane).
        self._long = set()
        if self.light.kind == "directional" and self._unit_points:
            unit_rects = clumping.object_summaries(self._unit_points, footprint)[0]
            self._long = {self._unit_keys[u] for u, rect in enumerate(unit_rects)
                          if len(self._units[u][1]) == 1 and clumping.rect_extent(rect) > limit}

    def _build_static(self) -> None:
        s = self.settings
        self._extent_scale, self._short = 1.0, False
        self._make_units()
        count = s.clump_count
        if count is not None and count > self.max_clumps:
            self.notes.append(f"{count} clumps asked, {self.max_clumps} fit the layer budget")
            count = self.max_clumps
        clumps, core, long_clumps, footprint = self._clumps_at_target(count)
        room = max(1, self.max_clumps - len(long_clumps))
        layers = self._layers_for(clumps, core)
        if layers > room:
            needed = layers + len(long_clumps)
            self._short = True
            self.notes.append(
                f"{needed} clumps would meet {s.texels_per_metre:g} "
                f"texels/m; {self.max_clumps} layers fit the {s.budget_mib:g} MiB budget and "
                "the GL's layers, so texels are coarser")
            if count is None and self.light.kind == "directional":
                # The parts were split for the target's maps, which the budget cannot give:
                # split them for the maps it can (a clump count goes as the inverse square of
                # the clumps' width). Parts cut finer serve no clump, and more single faces
                # would count as long ones, drawn into every map they cross. Not around a
                # spot or point light, where a clump may take one layer or a cube's six: there
                # the count does not follow the width, and a lamp moved a little would clump
                # anew into a different number of maps.
                self._extent_scale = math.sqrt(needed / self.max_clumps)
                self._make_units()
                clumps, core, long_clumps, footprint = self._clumps_at_target(None)
                room = max(1, self.max_clumps - len(long_clumps))
            # A clump around a point light takes a cube's six layers: fewer clumps until the
            # maps of all of them fit.
            count = room
            points = self._unit_points
            while True:
                clumps = clumping.make_clumps([points[u] for u in core], footprint, s.clumping,
                                              0.0, count)
                over = self._layers_for(clumps, core) - room
                if over <= 0 or count == 1:
                    break
                count = max(1, min(count - 1, len(clumps) - over))
        for layers in self._clump_layers:
            for layer in layers:
                self._give_layer(layer)
        self._clump_keys = [[self._unit_keys[core[m]] for m in c.members] for c in clumps]
        self._clump_keys += long_clumps
        self._clump_layers = [[self._take_layer()] for _ in self._clump_keys]
        self._shared_faces: dict[tuple, tuple] = {}  # a clump's own keys -> faces it shares
        self._dirty = set(range(len(self._clump_keys)))
        self._refresh_static()

    def _clumps_at_target(self, count: int | None):
        """The units' clumps at the density target (or ``count`` of them), the core units
        they are made of, the long faces' clumps, and the light's footprint function."""
        s = self.settings
        points = self._unit_points
        footprint, per_metre = _footprint(self.light, points)
        long_keys = [k for k in self._unit_keys if k in self._long]
        core = [u for u, k in enumerate(self._unit_keys) if k not in self._long]
        long_clumps = self._long_clumps(long_keys, footprint)
        if count is not None:
            count = max(1, min(count, len(core)) - len(long_clumps)) if core else None
        clumps = clumping.make_clumps([points[u] for u in core], footprint, s.clumping,
                                      self._max_extent(per_metre), count) if core else []
        return clumps, core, long_clumps, footprint

    def _layers_for(self, clumps: list[clumping.Clump], core: list[int]) -> int:
        """The layers these clumps' maps take: one each, six for a clump around the light."""
        if self.light.kind == "directional":
            return len(clumps)
        return sum(1 if self._one_frustum(
            np.concatenate([self._unit_points[core[m]] for m in c.members]))
            else CUBE_FACES for c in clumps)

    def _one_frustum(self, points: np.ndarray) -> bool:
        """Whether one frustum from a spot or point light holds ``points``; around a point light
        only one no wider than a cube's face, whose texels it would otherwise coarsen."""
        max_tan = CUBE_FACE_TAN if self.light.kind == "point" else MAX_TAN
        return holds_in_one_frustum(points, self.light.position, max_tan)

    def _long_clumps(self, keys: list[tuple[str, int]], footprint) -> list[list[tuple[str, int]]]:
        """The long faces ``keys`` in clumps of their own: few, each about as wide as two of
        the longest, since they only shadow what lies between the other clumps."""
        if not keys:
            return []
        index = {key: u for u, key in enumerate(self._unit_keys)}
        points = [self._unit_points[index[key]] for key in keys]
        widest = float(max(clumping.rect_extent(r)
                           for r in clumping.object_summaries(points, footprint)[0]))
        return [[keys[m] for m in c.members]
                for c in clumping.make_clumps(points, footprint, self.settings.clumping,
                                              2.0 * widest)]

    def _refresh_static(self) -> None:
        """Clumps, fits and map records from the member keys (after any change)."""
        s = self.settings
        points = self._unit_points
        index = {key: u for u, key in enumerate(self._unit_keys)}
        footprint = (clumping.directional_footprint(self._light_rot)
                     if self.light.kind == "directional" else None)
        self._drop_empty_clumps()
        self.clumps, self.static_maps, self._map_of_clump = [], [], {}
        self._clump_geometry: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}
        self._clump_spheres: dict[int, tuple[np.ndarray, float]] = {}  # for the view's need
        self._face_reach: dict[int, list[tuple[np.ndarray, float]]] = {}  # a cube's faces'
        self.static_pieces = []
        piece_of: dict[int, int] = {}
        member_rects = []
        for keys in self._clump_keys:
            members = tuple(sorted(index[key] for key in keys))
            rects = (clumping.object_summaries([points[u] for u in members], footprint)[0]
                     if footprint is not None else None)
            member_rects.append(rects)
            self.clumps.append(clumping.Clump(
                members=members,
                rect=clumping.union_rect(rects) if rects is not None else np.zeros(4)))
            for u in members:
                piece_of[u] = len(self.static_pieces)
                self.static_pieces.append(self._units[u])
        self.static_pieces += self._beyond
        long_units = sorted(index[key] for key in self._long if key in index)
        long_set = set(long_units)
        long_corners = (np.stack([footprint(self.geom.static_corners(*self._units[u]))
                                  for u in long_units])
                        if footprint is not None and long_units else None)
        for k, clump in enumerate(self.clumps):
            members, rects = clump.members, member_rects[k]
            fallback = long_corners is not None and members[0] in long_set
            extra: list[int] = []
            if long_corners is not None and not fallback:
                # Long faces that cross this map's rectangle are drawn into it too.
                core_points = np.concatenate([points[u] for u in members])
                rect = fit_directional(core_points, self._light_rot, s.clump_resolution).rect
                meet = clumping.triangles_meet_rects(long_corners, rect[None])[:, 0]
                extra = [u for u, m in zip(long_units, meet, strict=True) if m]
            own = tuple(self._clump_keys[k])
            if self._shared_faces.get(own) != tuple(self._unit_keys[u] for u in extra):
                self._shared_faces[own] = tuple(self._unit_keys[u] for u in extra)
                self._dirty.add(k)
            pieces = [piece_of[u] for u in (*members, *extra)]
            statics = sorted({self._units[u][0] for u in (*members, *extra)})
            cover = rects
            if extra:  # the long faces' footprints, cut to the map's rectangle
                theirs = clumping.object_summaries([points[u] for u in extra], footprint)[0]
                theirs[:, :2] = np.maximum(theirs[:, :2], rect[:2])
                theirs[:, 2:] = np.minimum(theirs[:, 2:], rect[2:])
                cover = np.concatenate([rects, theirs])
            depth = np.concatenate([points[u] for u in extra]) if extra else None
            core_points = np.concatenate([points[u] for u in members])
            self._clump_geometry[k] = (core_points, depth)
            self._clump_spheres[k] = bounding_sphere(core_points)
            fits = self._clump_fits(k, core_points, depth)
            if len(fits) > 1:  # a cube: each face's need follows what it holds
                self._face_reach[k] = cube_face_reach(core_points, self.light.position,
                                                      self.light.range)
            self._map_of_clump[k] = []
            for fit, layer in zip(fits, self._clump_layers[k], strict=False):
                self._map_of_clump[k].append(len(self.static_maps))
                self.static_maps.append(MapRecord(
                    name=f"clump_{k}", kind=KIND_FALLBACK if fallback else KIND_CLUMP, fit=fit,
                    layer=layer, viewport=s.clump_resolution,
                    objects=[self.geom.static_object(i) for i in statics], cover=cover,
                    pieces=pieces))
        self._clump_density = self._density_reached()
        self._index_view_maps()
        self._make_view_budget()

    def _density_reached(self) -> float:
        """The clump maps' texels per metre: the target, or under a directional light the
        median of the maps' own where the budget held them coarser (of the long faces' maps
        where there are no others)."""
        target = self.settings.texels_per_metre
        texels = ([m.fit.texel for m in self.static_maps if m.kind == KIND_CLUMP]
                  or [m.fit.texel for m in self.static_maps])
        if self.light.kind != "directional" or not texels:
            return target
        return min(target, 1.0 / float(np.median(texels)))

    def _drop_empty_clumps(self) -> None:
        """Clumps left without members go, and give back their layers."""
        keep = [k for k, keys in enumerate(self._clump_keys) if keys]
        for k in range(len(self._clump_keys)):
            if k not in keep:
                for layer in self._clump_layers[k]:
                    self._give_layer(layer)
        old_dirty = self._dirty
        self._clump_keys = [self._clump_keys[k] for k in keep]
        self._clump_layers = [self._clump_layers[k] for k in keep]
        self._dirty = {new for new, k in enumerate(keep) if k in old_dirty}

    def _clump_fits(self, k: int, points: np.ndarray, depth_points: np.ndarray | None = None
                    ) -> list[MapFit]:
        """The maps of clump ``k``: one fit, or the faces of a cube around a light inside it.
        ``depth_points`` (directional light) widen only the depth range: faces it shares.

        Takes or gives back layers so that the clump holds one per map (at least one).
        """
        res = self.settings.clump_resolution
        light = self.light
        fits: list[MapFit] = []
        if light.kind != "directional" and not self._one_frustum(points):
            fits = fit_cube_faces(points, light.position, res)
            spare = self.layer_limit - self._fixed_layers + len(self._free)
            if len(fits) - len(self._clump_layers[k]) > spare:
                self.notes.append(f"clump {k} surrounds the light but {spare} free layers "
                                  "cannot hold a cube of maps; its widest frustum is used")
                fits = []
        if not fits:
            fit = (fit_directional(points, self._light_rot, res, depth_points=depth_points)
                   if light.kind == "directional" else self._fit(points, res))
            fits = [fit] if fit is not None else []
        layers = self._clump_layers[k]
        before = list(layers)
        while len(layers) < max(1, len(fits)):
            layers.append(self._take_layer())
        while len(layers) > max(1, len(fits)):
            self._give_layer(layers.pop())
        if layers != before:
            self._dirty.add(k)
        return fits

    def update_statics(self, geom: PackedGeometry, changed: set[str]) -> list[int]:
        """Statics were added, removed or moved (their names in ``changed``).

        Every part of a changed static leaves its clump (that clump's map is re-rendered: its
        old place). A static that still exists comes back: where it fits one map at the
        density target, each of its parts joins the clump whose footprint overlaps its own the
        most, or the nearest one (re-rendered too: its new place); the parts of a larger one (a
        level in one file) are clumped anew among themselves, in clumps of their own. Other
        clumps keep their cached maps. Returns the indices of the clumps that will be
        re-rendered.
        """
        self.geom = geom
        self._ground = self._ground_height()
        self._make_units()
        index = {key: u for u, key in enumerate(self._unit_keys)}
        for k, keys in enumerate(self._clump_keys):
            kept = [key for key in keys if key in index and key[0] not in changed]
            if len(kept) != len(keys):
                self._clump_keys[k] = kept
                self._dirty.add(k)
        self._drop_empty_clumps()
        arrivals = [key for key in self._unit_keys if key[0] in changed]
        footprint, per_metre = _footprint(self.light, self._unit_points)
        by_static: dict[str, list[tuple[str, int]]] = {}
        for key in arrivals:
            by_static.setdefault(key[0], []).append(key)
        arrivals = []
        for keys in by_static.values():
            core = [key for key in keys if key not in self._long]
            own = clumping.make_clumps([self._unit_points[index[key]] for key in core],
                                       footprint, self.settings.clumping,
                                       self._max_extent(per_metre)) if core else []
            if len(own) == 1 and len(core) == len(keys):  # it fits one map: it joins the others
                arrivals += keys
                continue
            groups = [[core[m] for m in clump.members] for clump in own]
            groups += self._long_clumps([key for key in keys if key in self._long], footprint)
            for group in groups:
                self._clump_keys.append(group)
                self._clump_layers.append([self._take_layer()])
                self._dirty.add(len(self._clump_keys) - 1)
        if arrivals:
            # Candidates: the clumps of other faces, not the fallback maps of long faces.
            rects = [clumping.object_summaries(
                [self._unit_points[index[key]] for key in keys], footprint)[0]
                if keys and keys[0] not in self._long else np.zeros((0, 4))
                for keys in self._clump_keys]
            own_rects = clumping.object_summaries(
                [self._unit_points[index[key]] for key in arrivals], footprint)[0]
            for key, own in zip(arrivals, own_rects, strict=True):
                k = self._nearest_clump(own, rects)
                if k is None:
                    self._clump_keys.append([])
                    self._clump_layers.append([self._take_layer()])
                    rects.append(np.zeros((0, 4)))
                    k = len(self._clump_keys) - 1
                self._clump_keys[k].append(key)
                rects[k] = np.vstack([rects[k], own[None]])
                self._dirty.add(k)
        self._refresh_static()
        return sorted(self._dirty)

    def _nearest_clump(self, rect: np.ndarray, clump_rects: list[np.ndarray]) -> int | None:
        """The clump overlapping ``rect`` most, else the one whose footprint is nearest."""
        best, best_key = None, None
        for k, rects in enumerate(clump_rects):
            if not len(rects):
                continue
            u = clumping.union_rect(rects)
            w = min(u[2], rect[2]) - max(u[0], rect[0])
            h = min(u[3], rect[3]) - max(u[1], rect[1])
            overlap = max(w, 0.0) * max(h, 0.0)
            gap = math.hypot(max(-w, 0.0), max(-h, 0.0))
            key = (-overlap, gap)
            if best_key is None or key < best_key:
                best, best_key = k, key
        return best

    def update_characters(self, geom: PackedGeometry) -> None:
        """Characters were added or removed: free and hand out their layers."""
        self.geom = geom
        self._char_boxes = self._names = None
        self._assign_characters()
        if self.view_budget is not None:  # the characters' squares change: place all anew
            self.view_budget = None
            self._make_view_budget()
            self._dirty = set(range(len(self._clump_keys)))

    # -- frame ------------------------------------------------------------------------------
    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        """The maps for this frame; ``models`` are the characters' (n, 4, 4) matrices."""
        maps = list(self.static_maps)
        backlog = 0
        self._reserved_squares = None
        if self._given is not None:  # placed in the lights' shared atlas
            placements, drawn, self._reserved_squares = self._given
            self._given = None
            render_static = sorted(self._placed(maps, placements, drawn))
        elif self.view_budget is not None and view is not None and view.size is not None:
            requests, must = self.view_requests(view)
            placements, drawn = self.view_budget.place(requests, must)
            self._reserved_squares = self.view_budget.reserved
            render_static = sorted(self._placed(maps, placements, drawn))
            backlog = self.view_budget.backlog
        else:
            render_static = sorted(i for k in self._dirty for i in self._map_of_clump.get(k, []))
        render_dynamic = []
        counts = self._character_maps(models, view, maps, render_dynamic)
        self._dirty = set()
        # The needs of this frame's requests, where this plan made them; only counted maps
        # need what :meth:`served` reads.
        asked, self._asked = self._asked, None
        if self.counts_pixels:
            self._planned = [(key, i, maps[i].viewport,
                              0.0 if asked is None else float(asked[q]))
                             for q, (key, i) in enumerate(zip(self._view_maps["keys"],
                                                              self._view_maps["records"],
                                                              strict=True))]
        return ShadowPlan(resolution=self.resolution, maps=maps,
                          render_static=render_static, render_dynamic=render_dynamic,
                          static_pieces=self.static_pieces, characters=counts,
                          backlog=backlog)

    def _placed(self, maps: list[MapRecord], placements: list[Placement], drawn: set[int]
                ) -> list[int]:
        """Replace the clump maps' records in ``maps`` by their view-sized ``placements`` (in
        the order of :meth:`view_requests`); returns the records drawn (``drawn`` of them)."""
        records = self._view_maps["records"]
        made = {}
        for i, placement in zip(records, placements, strict=True):
            square, fit = placement.squares[0], placement.fits[0]
            # The record of a map whose square and fit stay is the last frame's: most stay.
            last = self._placed_records.get(i)
            if last is not None and last[0] is maps[i] and last[1] is fit and last[2] == square:
                made[i] = last
                maps[i] = last[3]
                continue
            made[i] = (maps[i], fit, square, dataclasses.replace(
                maps[i], fit=fit, layer=square.layer, viewport=placement.side,
                origin=(square.x, square.y)))
            maps[i] = made[i][3]
        self._placed_records = made
        return [records[n] for n in drawn]

    def _fits_at(self, k: int, side: int) -> list[MapFit]:
        """Clump k's maps fitted at ``side`` texels: as many as it has, of the same kind."""
        points, depth = self._clump_geometry[k]
        count = len(self._map_of_clump.get(k, []))
        light = self.light
        if light.kind == "directional":
            return [fit_directional(points, self._light_rot, side, depth_points=depth)]
        if count > 1:
            return fit_cube_faces(points, light.position, side)
        fit = self._fit(points, side)
        return [fit] if fit is not None else []

    def _character_maps(self, models: np.ndarray, view, maps: list[MapRecord],
                        render_dynamic: list[int]) -> dict[str, int]:
        """Append this frame's character maps (game/shadows/crowd.py) to ``maps``; returns
        their counts for the stats."""
        g, s, light = self.geom, self.settings, self.light
        n = g.n_characters
        if not n:
            return {}
        models = np.asarray(models, float)
        visible = self.reached_characters(models)
        if not visible.any():  # a lamp whose range holds no character now
            return {"character_maps": 0, "characters_skipped": n, "characters_grouped": 0,
                    "character_maps_shrunk": 0}
        if self._names is None:  # made anew by update_characters
            self._names = self._character_names()
            self.crowd.forget(set(self._names))
        names = self._names
        # Each character's bounding box, posed: its map's fit and cover need no more.
        if self._char_boxes is None or len(self._char_boxes) != n:
            self._char_boxes = np.stack([_box_corners(p) for p in g.character_points])
        placed = (np.einsum("nij,nkj->nki", models[:, :3, :3], self._char_boxes)
                  + models[:, None, :3, 3])
        centres = models[:, :3, 3]
        radii = np.asarray(g.character_radius, float)
        needed = np.full(n, np.inf)
        if view is not None and view.size is not None and s.character_texels_per_pixel > 0:
            ground = min(self._ground, float(placed[..., 1].min()))
            eye = None if light.kind == "directional" else np.asarray(light.position, float)
            volumes, bounded = crowd.shadow_volumes(centres, radii, light.kind, light.direction,
                                                    eye, ground)
            visible &= ~(bounded & crowd.outside_view(volumes, view.proj @ view.view))
            needed = crowd.texels_needed(volumes, centres, radii, view.view, view.proj,
                                         view.size[1], s.character_texels_per_pixel, eye)
            # A distant walker needs few texels per pixel, but a map much coarser than the
            # clump maps beside it gives its small shadow a blocky outline the statics' do not
            # have: the floor keeps the two of the same order.
            needed = np.maximum(needed, 2.0 * radii * self._clump_density
                                * CHARACTER_DENSITY_FLOOR)
        shown = np.flatnonzero(visible)
        sizes = self.crowd.sizes([names[i] for i in shown.tolist()], needed[shown])
        rects = None
        if light.kind == "directional":
            xy = centres[shown] @ self._light_rot[:2].T
            r = radii[shown][:, None]
            rects = np.concatenate([xy - r, xy + r], axis=1)
        room = self.max_maps - len(maps)
        planned = crowd.group(sizes, rects, self._character_resolution, room,
                              merge=s.character_texels_per_pixel > 0)
        shrunk = crowd.pack(planned, len(self._char_layers), s.clump_resolution)
        covers = fits = None
        if light.kind == "directional":
            xy = placed @ self._light_rot[:2].T              # (n, 8, 2) across the light
            z = placed @ self._light_rot[2]                  # (n, 8) along it
            covers = np.concatenate([xy.min(axis=1), xy.max(axis=1)], axis=1)
            fits = self._group_fits(planned, shown, z.min(axis=1), z.max(axis=1))
        drawn = 0
        first = g.character_object(0)
        shown_list = shown.tolist()
        for k, m in enumerate(planned):
            members = [shown_list[j] for j in m.members]
            fit = fits[k] if fits is not None else None
            if fit is None:
                fit = self._fit(placed[members].reshape(-1, 3), m.resolution)
            if fit is None:
                continue
            render_dynamic.append(len(maps))
            cover = None
            if covers is not None:  # a slice, not an index array, for a map of one member
                cover = covers[members] if len(members) > 1 else covers[members[0]:members[0] + 1]
            layer, origin = self._char_layers[m.layer], m.origin
            if self._reserved_squares is not None:  # the layer is a square of an atlas
                square = self._reserved_squares[m.layer]
                layer, origin = square.layer, (square.x + origin[0], square.y + origin[1])
            maps.append(MapRecord(name=f"character_{members[0]}", kind=KIND_CHARACTER, fit=fit,
                                  layer=layer, viewport=m.resolution,
                                  objects=[first + i for i in members],
                                  cover=cover, origin=origin))
            drawn += 1
        return {"character_maps": drawn, "characters_skipped": int(n - len(shown)),
                "characters_grouped": sum(len(m.members) for m in planned if len(m.members) > 1),
                "character_maps_shrunk": shrunk}

    def _group_fits(self, planned: list[crowd.CrowdMap], shown: np.ndarray,
                    z_lo: np.ndarray, z_hi: np.ndarray) -> list[MapFit | None]:
        """Directional light: the fits of the planned maps that carry a square, all at once
        (the members lie within their bounding spheres, so the square holds them all; their
        posed boxes' light-space depths ``z_lo``..``z_hi`` bound the depth); None for the
        others."""
        with_square = [k for k, m in enumerate(planned) if m.square is not None]
        out: list[MapFit | None] = [None] * len(planned)
        if not with_square:
            return out
        members = [planned[k].members for k in with_square]
        order = shown[np.concatenate(members)]
        starts = np.cumsum([0] + [len(m) for m in members[:-1]])
        squares = np.array([planned[k].square for k in with_square], float)
        texels = np.array([np.nan if planned[k].texel is None else planned[k].texel
                           for k in with_square])
        fits = fit_squares(self._light_rot, squares[:, :2], squares[:, 2],
                           np.minimum.reduceat(z_lo[order], starts),
                           np.maximum.reduceat(z_hi[order], starts),
                           np.array([planned[k].resolution for k in with_square]), texels)
        for k, fit in zip(with_square, fits, strict=True):
            out[k] = fit
        return out

    def mark_rendered_lost(self) -> None:
        """The array was re-created (resized): every cached layer must be drawn again."""
        self._dirty = set(range(len(self._clump_keys)))
