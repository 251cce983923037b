"""The records every hard-shadow method plans with: settings, map records, the frame's plan.

Kept apart from the methods (game/shadows/methods/) so that each of them depends on these
records and none on another.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from game.gpu import depth_bounds
from game.scene.geometry import Piece
from game.shadows.fit import MapFit

# KIND_CASCADE: keep in sync with shaders/shadow.glsl (the finest cascade holding a fragment wins).
# KIND_FALLBACK: a coarse map of long faces that the clump maps share (clumped); the shading pass
# reads it only where no clump map holds the fragment.
KIND_CLUMP, KIND_CHARACTER, KIND_ALL, KIND_CASCADE, KIND_FALLBACK = 0, 1, 2, 3, 4

# Defaults chosen so the accuracy bar of tests/shadows/test_accuracy.py holds without per-scene
# tuning.
TEXELS_PER_METRE = 96.0        # clump maps' texel-density target
CLUMP_RESOLUTION = 2048        # texels per side of a clump map (and of the array's layers)
MIN_SHORT_RESOLUTION = 1024    # clump maps short of layers at the density target are halved
#                                to this side at least
CHARACTER_RESOLUTION = 512     # most texels per side of a character's map
MIN_CHARACTER_RESOLUTION = 32  # fewest texels per side of a character's map
CHARACTER_TEXELS_PER_PIXEL = 4.0  # a character map's texels per screen pixel where its shadow
#                                  can be nearest the camera (0: always the most, every frame)
CHARACTER_DENSITY_FLOOR = 1.0  # ... and at least this share of the clump maps' texels per metre
SINGLE_RESOLUTION = 4096       # the baseline's one map
LAMP_RESOLUTION = 1024         # the baselines' maps (or cube faces) of a light with a range
NORMAL_BIAS_TEXELS = 0.25      # offset along the normal, times sin(angle to the light)
DEPTH_BIAS_TEXELS = 1.0        # offset towards the light
SLOPE_BIAS_TEXELS = 1.0        # offset towards the light, times tan(angle to the light)
MAX_SLOPE = 8.0                # cap on that tan, for grazing light
SHADOW_BUDGET_MIB = 512        # depth-array memory the clumped method's lights share
DEPTH_TEXEL_BYTES = 4          # GL_DEPTH_COMPONENT32F
MAX_CLUMP_RESOLUTION = 4096    # view-sized clump maps: the largest side (the array's layers)
MIN_CLUMP_RESOLUTION = 128     # view-sized clump maps: the smallest side
VIEW_TEXELS_PER_PIXEL = 8.0    # view-sized clump maps: texels per pixel where their shadow
#                                can be nearest the camera
MAX_MAP_RENDERS = 16           # view-sized clump maps: most that change side in one frame
CASCADES = 4                   # csm: cascades (Bevy, Godot and Filament default to 4)
CASCADE_LAMBDA = 0.75          # csm: practical split blend, 1 logarithmic, 0 uniform
CASCADE_RESOLUTION = 2048      # csm: texels per side of each cascade


def layer_bytes(resolution: int) -> int:
    """The bytes of one depth-array layer of ``resolution`` texels per side, with its depth
    bounds (game/gpu/depth_bounds.py)."""
    return DEPTH_TEXEL_BYTES * resolution * resolution + depth_bounds.layer_bytes(resolution)


@dataclass
class ShadowSettings:
    """Everything a user can change about the hard shadows (command-line flags, the overlay)."""

    method: str = "clumped"
    clumping: str = "light"
    clump_count: int | None = None
    texels_per_metre: float = TEXELS_PER_METRE
    clump_resolution: int = CLUMP_RESOLUTION
    character_resolution: int = CHARACTER_RESOLUTION
    min_character_resolution: int = MIN_CHARACTER_RESOLUTION
    character_texels_per_pixel: float = CHARACTER_TEXELS_PER_PIXEL
    single_resolution: int = SINGLE_RESOLUTION
    lamp_resolution: int = LAMP_RESOLUTION
    normal_bias: float = NORMAL_BIAS_TEXELS
    depth_bias: float = DEPTH_BIAS_TEXELS
    slope_bias: float = SLOPE_BIAS_TEXELS
    max_slope: float = MAX_SLOPE
    pcf: bool = False
    grid: str = "auto"
    # depth-array memory the clumped method may use; None: SHADOW_BUDGET_MIB, and no light
    # gets less than the baselines' maps of it take (game/shadows/lights.py)
    budget_mib: float | None = None
    # clumped: size each clump map by what the view needs, in the memory the fixed maps would
    # take (else every clump map has clump_resolution texels per side)
    view_resolution: bool = False
    max_clump_resolution: int = MAX_CLUMP_RESOLUTION
    view_texels_per_pixel: float = VIEW_TEXELS_PER_PIXEL
    max_map_renders: int = MAX_MAP_RENDERS
    cascades: int = CASCADES
    cascade_lambda: float = CASCADE_LAMBDA
    cascade_resolution: int = CASCADE_RESOLUTION


def budget_of(settings: ShadowSettings) -> float:
    """The memory budget the lights share, in MiB: ``budget_mib``, or by default
    :data:`SHADOW_BUDGET_MIB`."""
    return SHADOW_BUDGET_MIB if settings.budget_mib is None else settings.budget_mib


def shadow_reach(settings: ShadowSettings) -> float:
    """How far the shader may look from a fragment, in texels: the bias offsets (as in
    shaders/shadow.glsl) plus one PCF tap and one for rounding."""
    s = settings
    return s.normal_bias + s.depth_bias + s.slope_bias * s.max_slope + 2.0


def map_names(base: str, count: int) -> list[str]:
    """Names of a caster set's maps: ``base`` for one, ``base_face_K`` for a cube's faces."""
    return [base] if count == 1 else [f"{base}_face_{k}" for k in range(count)]


@dataclass
class MapRecord:
    """One shadow map: its projection, its layer, and the objects drawn into it."""

    name: str
    kind: int
    fit: MapFit
    layer: int
    viewport: int          # texels per side used, from the layer's corner
    objects: list[int]     # global object indices
    # Directional light: light-space rectangles of the casters drawn into the map. Much tighter
    # than the map's own rectangle when a clump is spread out; the map grid lists a map for a
    # cell only where one of these (grown by the bias reach) overlaps it.
    cover: np.ndarray | None = None
    # Spot or point light: bounding spheres (K, 4: centre, radius) of the casters drawn into the
    # map. The map grid lists the map for a cell of directions only where the cone from the
    # light through one of them (grown by the bias reach) meets the cell's cone: a cube face
    # around the light then reaches the fragments behind its casters, not its whole quarter.
    spheres: np.ndarray | None = None
    # A clump of parts: the pieces drawn (indices into the plan's ``static_pieces``), where
    # ``objects`` only names the statics they belong to. None: the objects are drawn whole.
    pieces: list[int] | None = None
    # Texel offset of the map's square in its layer (character maps share layers).
    origin: tuple[int, int] = (0, 0)
    # A tile of a partition of the light plane (directional light): the light-space square
    # (xmin, ymin, xmax, ymax) for which this map alone holds every static caster. The map grid
    # lists the map in exactly the cells of its tile (game/shadows/map_grid.py).
    tile: np.ndarray | None = None


@dataclass(frozen=True)
class CharacterCounts:
    """A frame's character maps, for the stats: maps drawn, characters skipped (no visible
    shadow), characters grouped (sharing a map), and maps shrunk for want of layers."""

    maps: int = 0
    skipped: int = 0
    grouped: int = 0
    shrunk: int = 0

    def __add__(self, other: CharacterCounts) -> CharacterCounts:
        return CharacterCounts(self.maps + other.maps, self.skipped + other.skipped,
                               self.grouped + other.grouped, self.shrunk + other.shrunk)

    def as_dict(self) -> dict[str, int]:
        """The counts under the names the stats files and the bench's columns use."""
        return {"character_maps": self.maps, "characters_skipped": self.skipped,
                "characters_grouped": self.grouped, "character_maps_shrunk": self.shrunk}


@dataclass
class ShadowPlan:
    resolution: int                  # texels per side of the array's layers
    maps: list[MapRecord]            # every map the shading pass may sample
    render_static: list[int] = field(default_factory=list)   # indices into maps
    render_dynamic: list[int] = field(default_factory=list)
    # The statics' faces in clump order, for the index buffer (game/scene/geometry.layout).
    static_pieces: list[Piece] | None = None
    # The character maps of the frame (None: the method plans no character maps apart).
    characters: CharacterCounts | None = None
    backlog: int = 0  # view-sized clump maps whose new side waits for a later frame
    # Each light's first map (game/shadows/lights.py): the maps of light k start at
    # light_first_maps[k].
    light_first_maps: list[int] = field(default_factory=lambda: [0])
