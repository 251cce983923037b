"""The protocol every hard-shadow method implements: plan the maps of one light, frame by frame.

The core, :class:`ShadowMethod`, is what every method implements. Two optional capabilities are
protocols of their own, which game/shadows/lights.py checks once per method: sharing the memory
budget between lights (:class:`SharesBudget`) and clump maps sized by the view's pixel counts
(:class:`ViewSized`).

A method only plans. It decides which maps exist, what each holds and which must be drawn this
frame (a :class:`~game.shadows.plan.ShadowPlan`); the render layer owns the GL objects and draws
what the plan lists. Planning is kept apart from drawing as in Filament, whose
``ShadowMapManager`` decides which maps exist while each ``ShadowMap`` fits one.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar

import numpy as np

from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.atlas import Square
from game.shadows.light_kinds import kind_of
from game.shadows.plan import MapRecord, ShadowPlan, ShadowSettings, layer_bytes
from game.shadows.view_budget import ClumpRequest, Placement

# Where the shading pass's visibility of the hard light comes from.
VISIBILITY_MAPS = "maps"      # the depth maps the method plans
VISIBILITY_TRACED = "traced"  # exact rays from the compute tracer over the frame's G-buffer


def bounding_sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """A sphere holding ``points``: the centre of their box and the farthest point's distance."""
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    return centre, float(np.linalg.norm(points - centre, axis=1).max())


def triangle_spheres(corners: np.ndarray) -> np.ndarray:
    """(n, 4) bounding spheres (centre, radius) of the triangles whose corners are ``corners``
    ((3n, 3))."""
    tri = np.asarray(corners, float).reshape(-1, 3, 3)
    centre = (tri.min(axis=1) + tri.max(axis=1)) / 2
    radius = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1)
    return np.concatenate([centre, radius[:, None]], axis=1)


SPLIT_DEPTH = 4  # halvings of a triangle whose sphere holds the light: 1/16 of its side


def caster_spheres(points: np.ndarray, corners: Callable[[], np.ndarray],
                   eye: np.ndarray) -> np.ndarray:
    """Bounding spheres (K, 4) of one caster as a light at ``eye`` sees it: the sphere of its
    ``points``, or, where that sphere holds the light (a lamp beside its own post), spheres of
    the triangles of ``corners()`` ((3n, 3)), a triangle whose sphere still holds it split in
    four, up to SPLIT_DEPTH times: the light's directions that the caster can cover are then
    not all of them."""
    if not len(points):
        return np.zeros((0, 4))
    eye = np.asarray(eye, float)
    centre, radius = bounding_sphere(points)
    if np.linalg.norm(eye - centre) > radius:
        return np.array([[*centre, radius]])
    tri, out = np.asarray(corners(), float).reshape(-1, 3, 3), []
    for depth in range(SPLIT_DEPTH + 1):
        spheres = triangle_spheres(tri)
        holds = np.linalg.norm(spheres[:, :3] - eye, axis=1) <= spheres[:, 3]
        if depth == SPLIT_DEPTH or not holds.any():
            out.append(spheres)
            break
        out.append(spheres[~holds])
        a, b, c = (tri[holds, j] for j in range(3))
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        tri = np.concatenate([np.stack(t, axis=1) for t in
                              ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return np.concatenate(out)


def reached_statics(geom: PackedGeometry, light: Light) -> list[int]:
    """The statics a spot or point light's range and cone can reach (all for others)."""
    if not kind_of(light).limits_reach(light):
        return list(range(geom.n_statics))
    return [i for i, p in enumerate(geom.static_points)
            if len(p) and light.reaches(*bounding_sphere(p))]


def reached_characters(geom: PackedGeometry, light: Light, models: np.ndarray) -> np.ndarray:
    """Per character, whether the light can reach it at its pose in ``models``."""
    n = geom.n_characters
    if not kind_of(light).limits_reach(light) or not n:
        return np.ones(n, bool)
    centres = np.asarray(models, float)[:, :3, 3]
    return np.array([light.reaches(centres[i], float(geom.character_radius[i]))
                     for i in range(n)], bool)


class ShadowMethod(ABC):
    """A hard-shadow method: the maps of the scene's light for every frame.

    Subclasses set :attr:`name` (the command line's ``--method``) and :attr:`summary`, and
    register in :mod:`game.shadows.registry`. Its properties only read what planning decided.
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    visibility: ClassVar[str] = VISIBILITY_MAPS
    # The ShadowSettings fields that size this method's maps; each is clamped to the GL's
    # GL_MAX_TEXTURE_SIZE (game/shadows/budget.py).
    resolution_fields: ClassVar[tuple[str, ...]] = ()
    # The ShadowSettings fields only this method reads (resolution_fields among them); the bias,
    # PCF and grid fields apply to every method. ``bench --param`` sweeps them per method.
    parameters: ClassVar[tuple[str, ...]] = ()
    # Whether the shadow memory budget bounds the array (else the resolution asked is used).
    budgeted: ClassVar[bool] = False

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int, max_maps: int | None = None):
        self.geom = geom
        self.light = light
        self.settings = settings
        self.max_layers = max_layers
        # Map records the shading pass holds; maps may share layers, so this may be more.
        self.max_maps = max_layers if max_maps is None else max_maps
        self.notes: list[str] = []   # one line each: how the method degraded, and why
        self._restated: str | None = None

    def note(self, text: str) -> None:
        """Say once how the method degraded (a method planned again says it again)."""
        if text not in self.notes:
            self.notes.append(text)

    def restate(self, text: str | None) -> None:
        """Say ``text`` in place of what the last call said: a note on a map that is fitted
        anew when the light or the statics change holds only while that fit does."""
        if self._restated in self.notes:
            self.notes.remove(self._restated)
        self._restated = text
        if text is not None:
            self.note(text)

    @classmethod
    def min_layers(cls, settings: ShadowSettings, n_characters: int) -> int:
        """The fewest array layers the method can work with (for the memory budget)."""
        return 1

    @property
    @abstractmethod
    def resolution(self) -> int:
        """Texels per side of the array's layers."""

    @property
    @abstractmethod
    def layers(self) -> int:
        """Layers the array needs."""

    @property
    def memory_mib(self) -> float:
        """The depth memory the method's layers take."""
        return self.layers * layer_bytes(self.resolution) / 2**20

    @property
    def reserved_layers(self) -> int:
        """The layers kept for it beside other lights': the most it may take while it runs."""
        return self.layers

    @abstractmethod
    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        """The maps of this frame; ``models`` are the characters' (n, 4, 4) matrices and
        ``view`` the camera's :class:`~game.render.frame.View` (view-dependent methods)."""

    @abstractmethod
    def set_light(self, light: Light) -> None:
        """The light moved: every map that depends on it is planned and drawn anew."""

    def update_statics(self, geom: PackedGeometry, changed: set[str]) -> list[int]:
        """Statics were added, removed or moved (their names in ``changed``).

        Returns the clumps whose maps the next frame re-renders. By default the method plans
        every map anew, as for a new light.
        """
        self.geom = geom
        self.set_light(self.light)
        return []

    def update_characters(self, geom: PackedGeometry) -> None:
        """Characters were added or removed. By default the method plans every map anew."""
        self.geom = geom
        self.set_light(self.light)

    def mark_rendered_lost(self) -> None:  # noqa: B027 - most methods cache nothing
        """The depth array was re-created: every cached map must be drawn again."""

    def view_note(self, view, maps: list[MapRecord], nearest: float) -> str | None:
        """What the method's own scheme loses in ``view``, where no receiver in view is nearer
        than view depth ``nearest``; ``maps`` are its last plan's. None by default: only a
        method whose maps follow the view can waste them on it."""
        return None


class SharesBudget(ABC):
    """A method whose share of the lights' memory budget sizes its maps: a light that takes
    less than its share hands the rest to the lights short of theirs (game/shadows/lights.py).
    """

    @property
    @abstractmethod
    def wants_memory(self) -> bool:
        """Whether a larger share of the memory budget would give its maps finer texels."""

    @abstractmethod
    def limit_memory(self, mib: float) -> None:
        """Hold any later re-planning to ``mib`` of the budget (what it takes now, or more)."""

    @property
    @abstractmethod
    def cube_side(self) -> int | None:
        """Texels per side of the cube of maps around a point light, where its casters
        surround it; None where there is none."""

    @property
    @abstractmethod
    def meets_density(self) -> bool:
        """Whether its maps meet the density target within its share."""


class ViewSized(ABC):
    """A method whose maps may be sized by the view: by the pixels the shading pass counts near
    each map's shadow edges, in an atlas of its own or one the lights share."""

    @property
    @abstractmethod
    def counts_pixels(self) -> bool:
        """Whether its maps are sized by the pixels near their shadow edges (:meth:`served`)."""

    @abstractmethod
    def served(self, pixels: np.ndarray) -> None:
        """Per map of the last plan counted (in the plan's order), the pixels that read it
        within a texel of its shadow edges (shaders/shadow.glsl)."""

    @property
    @abstractmethod
    def placed_blind(self) -> bool:
        """Whether its last plan placed its maps before any pixels were counted."""

    @abstractmethod
    def place_anew(self) -> None:
        """Place its maps anew on the next plan, by the pixels counted since."""

    @property
    @abstractmethod
    def fixed_texels(self) -> int:
        """The texels its fixed maps would keep: what it brings to a shared atlas."""

    @property
    @abstractmethod
    def reserved_sides(self) -> list[int]:
        """The sides of the squares its character maps keep in a shared atlas."""

    @abstractmethod
    def share_view_budget(self, side: int) -> None:
        """Place its maps in an atlas of ``side``-texel layers that the lights share."""

    @abstractmethod
    def view_requests(self, view) -> tuple[list[ClumpRequest], set[int]]:
        """Each map as the shared atlas sees it, and those that must be drawn this frame."""

    @abstractmethod
    def place_by_view(self, placements: list[Placement], drawn: set[int],
                      reserved: list[Square]) -> None:
        """This frame's placements from the shared atlas, handed over before :meth:`plan`."""
