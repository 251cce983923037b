"""The Embree shadow reference against shadows worked out by hand (no renderer, no GL).

A sphere above a floor casts a shadow whose outline is known in closed form: a ground point is in
shadow exactly when its ray toward the light passes within the sphere's radius of its centre. The
reference must agree everywhere except a thin band at the outline, where the tessellated sphere
and the true one differ.
"""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from game.reference.hard import (
    NON_CASTER_PREFIXES,
    Light,
    as_light,
    hard_visibility,
    hard_visibility_lights,
    load_frame,
    load_geometry,
    shadow_error,
)

pytest.importorskip("embreex", reason="the shadow reference needs embreex (pip install embreex)")

SPHERE_CENTRE = np.array([0.0, 2.0, 0.0])
SPHERE_RADIUS = 1.0
# Points this close to the analytic outline (metres, in distance from the ray to the centre) are
# not compared: an icosphere of subdivision 4 lies within 1 mm of the true sphere, so 2 cm is safe.
OUTLINE_MARGIN = 0.02
GRID_HALF = 5.0
GRID_N = 201


def sphere_over_floor() -> trimesh.Trimesh:
    """A unit sphere 2 m up, over a 12 m floor slab whose top is y = 0."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=SPHERE_RADIUS)
    sphere.apply_translation(SPHERE_CENTRE)
    floor = trimesh.creation.box([12.0, 0.2, 12.0])
    floor.apply_translation([0.0, -0.1, 0.0])
    return trimesh.util.concatenate([sphere, floor])


def floor_pixels() -> tuple[np.ndarray, np.ndarray]:
    """A (GRID_N, GRID_N) "frame" of points on the floor top, normals up."""
    xs = np.linspace(-GRID_HALF, GRID_HALF, GRID_N)
    x, z = np.meshgrid(xs, xs)
    position = np.stack([x, np.zeros_like(x), z], axis=-1).astype(np.float32)
    normal = np.zeros_like(position)
    normal[..., 1] = 1.0
    return position, normal


def distance_to_ray(points: np.ndarray, directions: np.ndarray, far: np.ndarray) -> np.ndarray:
    """Distance from SPHERE_CENTRE to each segment points + t * directions, 0 <= t <= far."""
    offset = SPHERE_CENTRE - points
    t = np.clip(np.einsum("...i,...i->...", offset, directions), 0.0, far)
    closest = points + directions * t[..., None]
    return np.linalg.norm(SPHERE_CENTRE - closest, axis=-1)


def compare_with_analytic(lit: np.ndarray, distance: np.ndarray) -> int:
    """Assert agreement away from the outline; return the number of shadowed points compared."""
    away = np.abs(distance - SPHERE_RADIUS) > OUTLINE_MARGIN
    expected_lit = distance > SPHERE_RADIUS
    disagree = away & ((lit >= 0.5) != expected_lit)
    assert not disagree.any(), f"{disagree.sum()} points disagree with the analytic shadow"
    # The band left out must be thin, or the comparison would prove little.
    assert away.mean() > 0.95
    return int((away & ~expected_lit).sum())


def test_directional_light_matches_analytic_shadow() -> None:
    mesh = sphere_over_floor()
    position, normal = floor_pixels()
    travel = np.array([0.3, -1.0, 0.2])
    travel /= np.linalg.norm(travel)
    lit = hard_visibility(mesh, position, normal, Light("directional", direction=tuple(travel)))

    assert lit.shape == (GRID_N, GRID_N) and lit.dtype == np.float32
    assert set(np.unique(lit)) <= {0.0, 1.0}
    distance = distance_to_ray(position.astype(np.float64), -travel, np.inf)
    shadowed = compare_with_analytic(lit, distance)
    # The shadow is an ellipse of area pi * r^2 / cos(angle) = about 3.4 m^2 = 1360 grid points.
    assert 1000 < shadowed < 1700


def test_point_light_shadow_is_the_projection_from_the_light() -> None:
    mesh = sphere_over_floor()
    position, normal = floor_pixels()
    light_position = np.array([0.5, 4.0, 0.3])
    lit = hard_visibility(mesh, position, normal, {"kind": "point", "position": light_position})

    offset = light_position - position.astype(np.float64)
    far = np.linalg.norm(offset, axis=-1)
    distance = distance_to_ray(position.astype(np.float64), offset / far[..., None], far)
    shadowed = compare_with_analytic(lit, distance)
    # The light is only 2 m above the sphere's centre, so the shadow is magnified: a disc of
    # radius 4 tan(30 deg) = 2.3 m, over four times the sphere's cross-section.
    cell_area = (2 * GRID_HALF / (GRID_N - 1)) ** 2
    assert shadowed > 4 * np.pi * SPHERE_RADIUS**2 / cell_area


def test_occluder_beyond_point_light_casts_no_shadow() -> None:
    mesh = sphere_over_floor()
    position, normal = floor_pixels()
    below_sphere = {"kind": "point", "position": [0.0, 0.8, 0.0]}
    lit = hard_visibility(mesh, position, normal, below_sphere)
    assert np.all(lit == 1.0)

    # The same sphere does shadow the floor under a light travelling straight down, so the test
    # above would fail if segments were treated as infinite rays.
    down = hard_visibility(mesh, position, normal, {"kind": "directional", "direction": [0, -1, 0]})
    assert (down == 0.0).sum() > 1000


def test_spot_light_visibility_ignores_the_cone() -> None:
    mesh = sphere_over_floor()
    position, normal = floor_pixels()
    where = [0.5, 4.0, 0.3]
    spot = {"kind": "spot", "position": where, "direction": [0, -1, 0], "cone": 20.0}
    point = {"kind": "point", "position": where}
    np.testing.assert_array_equal(
        hard_visibility(mesh, position, normal, spot),
        hard_visibility(mesh, position, normal, point),
    )


def test_missing_geometry_is_nan_and_back_faces_are_shadowed() -> None:
    # Sphere only: with no floor slab under the points, nothing but the N.L rule can shadow them.
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=SPHERE_RADIUS)
    mesh.apply_translation(SPHERE_CENTRE)
    position, normal = floor_pixels()
    position[0, :] = np.nan
    normal[0, :] = np.nan
    normal[1, :, 1] = -1.0  # facing away from a light above: the light cannot reach it
    lit = hard_visibility(mesh, position, normal, {"kind": "directional", "direction": [0, -1, 0]})
    assert np.isnan(lit[0]).all()
    assert np.all(lit[1] == 0.0)
    assert np.all(lit[2] == 1.0)  # the grid's edge row is far from the sphere's shadow
    assert not np.isnan(lit[1:]).any()


def test_missing_embree_fails_loudly(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "embreex", None)
    position, normal = floor_pixels()
    light = {"kind": "directional", "direction": [0, -1, 0]}
    with pytest.raises(RuntimeError, match="pip install embreex"):
        hard_visibility(sphere_over_floor(), position, normal, light)


def test_light_may_be_any_object_with_the_same_attributes() -> None:
    # A loaded scene's light has numpy fields and no mapping interface.
    mesh = sphere_over_floor()
    position, normal = floor_pixels()
    scene_light = SimpleNamespace(
        kind="point", direction=None, position=np.array([0.5, 4.0, 0.3]), cone=None
    )
    np.testing.assert_array_equal(
        hard_visibility(mesh, position, normal, scene_light),
        hard_visibility(mesh, position, normal, {"kind": "point", "position": [0.5, 4.0, 0.3]}),
    )


def test_light_from_mapping_checks_its_kind() -> None:
    light = Light.from_mapping({"kind": "spot", "position": [1, 2, 3], "direction": [0, -1, 0]})
    assert light.position == (1.0, 2.0, 3.0) and light.cone is None and light.range is None
    with pytest.raises(ValueError, match="kind"):
        Light("area", position=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="position"):
        Light("point")


def test_light_range_is_carried_and_checked() -> None:
    # Colour and intensity scale a light; they do not move its shadows, so they are ignored.
    light = Light.from_mapping({"kind": "point", "position": [1, 2, 3], "range": 8,
                                "color": [1, 0, 0], "intensity": 3.0})
    assert light.range == 8.0
    scene_light = SimpleNamespace(kind="spot", direction=np.array([0.0, -1.0, 0.0]),
                                  position=np.array([0.0, 3.0, 0.0]), cone=40.0, range=5.0)
    reference = as_light(scene_light)
    assert (reference.range, reference.cone) == (5.0, 40.0)
    with pytest.raises(ValueError, match="directional light has no range"):
        Light("directional", direction=(0.0, -1.0, 0.0), range=3.0)
    with pytest.raises(ValueError, match="positive"):
        Light("point", position=(0.0, 0.0, 0.0), range=0.0)


def test_one_embree_scene_serves_every_light() -> None:
    mesh = sphere_over_floor()
    position, normal = floor_pixels()
    lights = [{"kind": "directional", "direction": [0.3, -1.0, 0.2]},
              {"kind": "point", "position": [0.5, 4.0, 0.3]},
              {"kind": "spot", "position": [-1.0, 5.0, 0.0], "direction": [0, -1, 0],
               "cone": 30.0, "range": 2.0}]
    together = hard_visibility_lights(mesh, position, normal, lights)
    assert len(together) == 3
    for light, lit in zip(lights, together, strict=True):
        np.testing.assert_array_equal(lit, hard_visibility(mesh, position, normal, light))
    # The range ends the light's reach, not its rays: it shadows nothing by itself.
    no_range = {**lights[2], "range": None}
    np.testing.assert_array_equal(together[2], hard_visibility(mesh, position, normal, no_range))


def small_frame() -> tuple[np.ndarray, np.ndarray]:
    """A 2 x 4 frame on the floor, normals up except where set otherwise; one empty pixel."""
    position = np.zeros((2, 4, 3), dtype=np.float32)
    position[..., 0] = np.arange(4)
    position[..., 2] = np.arange(2)[:, None]
    normal = np.zeros_like(position)
    normal[..., 1] = 1.0
    position[0, 3] = np.nan
    normal[0, 3] = np.nan
    # Grazing: N.L = sin(3 degrees) = 0.05 under a light straight down, below the 0.1 cut-off.
    normal[1, 3] = [np.cos(np.radians(3.0)), np.sin(np.radians(3.0)), 0.0]
    return position, normal


def test_shadow_error_counts_by_hand() -> None:
    position, normal = small_frame()
    light = {"kind": "directional", "direction": [0.0, -1.0, 0.0]}
    nan = np.nan
    reference = np.array([[0, 0, 1, nan], [0, 1, 1, 0]], dtype=np.float32)
    method = np.array([[0, 1, 0.5, 0.0], [0.4, 0.2, 1, 1]], dtype=np.float32)
    # Considered: all but (0, 3) (no geometry) and (1, 3) (grazing) -> 6 pixels.
    # Shadowed in the reference: (0, 0), (0, 1), (1, 0) -> 3.
    # Misclassified: (0, 1) 1 vs 0 and (1, 1) 0.2 vs 1 -> 2; (1, 3) disagrees but is grazing.
    # Shadowed by either: the reference's 3 and the method's (1, 1) -> 4.
    result = shadow_error(method, reference, position, normal, light)
    assert result["considered"] == 6
    assert result["shadowed"] == 3
    assert result["shadowed_either"] == 4
    assert result["misclassified"] == 2
    assert result["error"] == pytest.approx(2 / 4)
    expected_mask = np.zeros((2, 4), dtype=bool)
    expected_mask[0, 1] = expected_mask[1, 1] = True
    np.testing.assert_array_equal(result["mask"], expected_mask)

    # A lower cut-off lets the grazing pixel in, and its disagreement counts.
    loose = shadow_error(method, reference, position, normal, light, min_ndotl=0.0)
    assert (loose["considered"], loose["shadowed"], loose["misclassified"]) == (7, 4, 3)


def test_shadow_error_without_shadows() -> None:
    position, normal = small_frame()
    light = {"kind": "directional", "direction": [0.0, -1.0, 0.0]}
    reference = np.ones((2, 4), dtype=np.float32)
    result = shadow_error(reference.copy(), reference, position, normal, light)
    assert (result["shadowed_either"], result["misclassified"], result["error"]) == (0, 0, 0.0)
    method = reference.copy()
    method[0, 0] = 0.0  # a shadow where the reference has none: wrong on every shadowed pixel
    result = shadow_error(method, reference, position, normal, light)
    assert (result["shadowed"], result["misclassified"], result["error"]) == (0, 1, 1.0)


def test_shadow_error_uses_direction_to_point_light_and_spot_cone() -> None:
    position, normal = small_frame()
    reference = np.zeros((2, 4), dtype=np.float32)
    method = np.ones((2, 4), dtype=np.float32)
    # A point light low on the -x side, 0.5 m up and 10 m away or more: N.L = 0.5 / distance < 0.1
    # for the upward normals, and the grazing pixel's normal faces away from it, so none count.
    low_light = {"kind": "point", "position": [-10.0, 0.5, 0.0]}
    low = shadow_error(method, reference, position, normal, low_light)
    assert low["considered"] == 0
    overhead = {"kind": "point", "position": [1.0, 3.0, 0.5]}
    assert shadow_error(method, reference, position, normal, overhead)["considered"] == 6
    # A narrow spot straight down over x = 1 only takes in the pixels near x = 1.
    spot = {"kind": "spot", "position": [1.0, 3.0, 0.5], "direction": [0, -1, 0], "cone": 30.0}
    narrow = shadow_error(method, reference, position, normal, spot)
    assert narrow["considered"] == 2 and narrow["mask"][:, 1].all()


def test_shadow_error_leaves_out_pixels_beyond_the_range() -> None:
    position, normal = small_frame()
    reference = np.zeros((2, 4), dtype=np.float32)
    method = np.ones((2, 4), dtype=np.float32)
    # A point light 3 m over (0, 0, 0): pixel (r, c) sits sqrt(9 + c^2 + r^2) m from it.
    # A range of 3.7 m takes in c <= 2 on row 0 (sqrt(13) = 3.61 m) and c <= 1 on row 1
    # (sqrt(14) = 3.74 m is beyond); (0, 3) has no geometry and (1, 3) faces away from the light.
    bulb = {"kind": "point", "position": [0.0, 3.0, 0.0], "range": 3.7}
    near = shadow_error(method, reference, position, normal, bulb)
    expected = np.array([[True, True, True, False], [True, True, False, False]])
    assert near["considered"] == 5
    np.testing.assert_array_equal(near["mask"], expected)
    unlimited = shadow_error(method, reference, position, normal, {**bulb, "range": None})
    assert unlimited["considered"] == 6 and unlimited["mask"][1, 2]
    # A spot's range and its cone both apply.
    spot = {**bulb, "kind": "spot", "direction": [0, -1, 0], "cone": 60.0}
    both = shadow_error(method, reference, position, normal, spot)
    # The cone takes in the points within tan(30 deg) * 3 = 1.73 m of (0, 0, 0): not (0, 2).
    assert both["considered"] == 4 and not both["mask"][0, 2]
    # The light lights nothing at its range: a point exactly that far is left out.
    edge = shadow_error(method, reference, position, normal, {**bulb, "range": 3.0})
    assert edge["considered"] == 0


def write_glb(path: Path) -> dict[str, trimesh.Trimesh]:
    """Write a three-node scene to a glb; return each node's mesh in world space."""
    transforms = {
        "floor_0": trimesh.transformations.translation_matrix([0.0, -0.1, 0.0]),
        "static_0": trimesh.transformations.compose_matrix(
            angles=np.radians([10.0, 45.0, 0.0]), translate=[3.0, 1.0, -2.0], scale=[2, 1, 1]
        ),
        "character_0": trimesh.transformations.translation_matrix([-1.0, 0.9, 4.0]),
    }
    local = {
        "floor_0": trimesh.creation.box([30.0, 0.2, 30.0]),
        "static_0": trimesh.creation.box([1.0, 2.0, 0.5]),
        "character_0": trimesh.creation.capsule(height=1.2, radius=0.3, count=[8, 8]),
    }
    scene = trimesh.Scene()
    for name, mesh in local.items():
        scene.add_geometry(
            mesh, node_name=name, geom_name=f"{name}_mesh", transform=transforms[name]
        )
    path.write_bytes(scene.export(file_type="glb"))
    return {name: local[name].copy().apply_transform(transforms[name]) for name in local}


def triangle_set(triangles: np.ndarray) -> np.ndarray:
    """Triangles as sorted rows, so two meshes compare regardless of face order."""
    rows = np.round(triangles.reshape(-1, 9), 4)
    return rows[np.lexsort(rows.T[::-1])]


def test_glb_round_trip_applies_node_transforms(tmp_path: Path) -> None:
    path = tmp_path / "frame_0000.glb"
    world = write_glb(path)
    mesh = load_geometry(path)
    expected = np.concatenate([m.triangles for m in world.values()])
    assert len(mesh.faces) == len(expected)
    np.testing.assert_allclose(triangle_set(mesh.triangles), triangle_set(expected), atol=1e-4)

    casters = load_geometry(path, skip_prefixes=NON_CASTER_PREFIXES)
    expected = np.concatenate([world["static_0"].triangles, world["character_0"].triangles])
    np.testing.assert_allclose(triangle_set(casters.triangles), triangle_set(expected), atol=1e-4)


def test_load_frame_reads_the_dump_arrays(tmp_path: Path) -> None:
    position, normal = small_frame()
    path = tmp_path / "frame_0000.npz"
    np.savez(
        path,
        position=position,
        normal=normal,
        object=np.zeros((2, 4), dtype=np.int32),
        names=np.array(["floor_0", "static_0"]),
        lit=np.ones((2, 4), dtype=np.float32),
        view=np.eye(4),
        proj=np.eye(4),
        size=np.array([4, 2]),
        time=np.float64(1.5),
    )
    frame = load_frame(path)
    assert frame["names"] == ["floor_0", "static_0"]
    assert frame["size"] == (4, 2) and frame["time"] == 1.5
    np.testing.assert_array_equal(frame["position"], position)
    assert "soft" not in frame
