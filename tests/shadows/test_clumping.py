"""Clumping of static objects into shadow-map groups (game/shadows/clumping.py); numpy, no GL."""

import itertools

import numpy as np
import pytest

from game.shadows.clumping import (
    STRATEGIES,
    Clump,
    directional_footprint,
    footprint_overlap,
    make_clumps,
    max_extent_for_density,
)

UNIT_CORNERS = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))


def box(centre, size=1.0) -> np.ndarray:
    """The 8 corners of an axis-aligned box, shape (8, 3)."""
    return np.asarray(centre, dtype=np.float64) + UNIT_CORNERS * np.asarray(size, dtype=np.float64)


def light_rot_towards(direction) -> np.ndarray:
    """Rows x, y, z of a directional light's frame; z points back towards the light (not up)."""
    z = -np.asarray(direction, dtype=np.float64)
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.array([x, np.cross(z, x), z])


# Sun straight overhead: light x = world x, light y = world -z, light z = world up.
OVERHEAD = directional_footprint(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]))


def random_town(n: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    centres = rng.uniform(0.0, 200.0, (n, 3))
    centres[:, 1] = 0.0
    return [box(c, rng.uniform(1.0, 6.0, 3)) for c in centres]


def rect_of(points: np.ndarray, footprint) -> np.ndarray:
    fp = footprint(points)
    return np.concatenate([fp.min(axis=0), fp.max(axis=0)])


def assert_partition(clumps: list[Clump], n: int) -> None:
    members = [i for c in clumps for i in c.members]
    assert sorted(members) == list(range(n))
    for c in clumps:
        assert list(c.members) == sorted(c.members)
        assert len(c.members) >= 1


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_every_object_in_exactly_one_clump(strategy):
    pts = random_town(300, seed=1)
    fp = directional_footprint(light_rot_towards([0.3, -1.0, 0.5]))
    clumps = make_clumps(pts, fp, strategy, max_extent=30.0)
    assert 1 < len(clumps) < 300
    assert_partition(clumps, len(pts))


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_rect_is_footprint_of_member_points(strategy):
    pts = random_town(120, seed=2)
    fp = directional_footprint(light_rot_towards([-0.6, -1.0, 0.2]))
    for c in make_clumps(pts, fp, strategy, max_extent=40.0):
        expected = rect_of(np.concatenate([pts[i] for i in c.members]), fp)
        np.testing.assert_allclose(c.rect, expected, rtol=0, atol=1e-9)
        assert c.rect.shape == (4,)


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_row_of_boxes_follows_density_target(strategy):
    # Ten unit boxes 10 m apart span 91 m; 25 m per map fits three boxes (21 m) but not four (31 m).
    pts = [box([10.0 * i, 0.0, 0.0]) for i in range(10)]
    clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=25.0)
    assert 4 <= len(clumps) <= 5
    assert_partition(clumps, 10)
    for c in clumps:
        assert c.extent <= 25.0
        # Clumps are runs of neighbours along the row.
        assert list(c.members) == list(range(c.members[0], c.members[-1] + 1))


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_every_clump_fits_unless_single(strategy):
    pts = random_town(400, seed=3)
    max_extent = max_extent_for_density(1024, 48.0)
    for c in make_clumps(pts, OVERHEAD, strategy, max_extent):
        assert c.extent <= max_extent or len(c.members) == 1


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_density_extremes(strategy):
    pts = [box([10.0 * i, 0.0, 0.0]) for i in range(10)]
    assert len(make_clumps(pts, OVERHEAD, strategy, max_extent=1000.0)) == 1
    assert len(make_clumps(pts, OVERHEAD, strategy, max_extent=0.5)) == 10


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_a_limit_stops_the_splits_early_and_changes_nothing_it_does_not_reach(strategy):
    pts = random_town(300, seed=4)
    full = make_clumps(pts, OVERHEAD, strategy, max_extent=12.0)
    assert len(full) > 40
    stopped = make_clumps(pts, OVERHEAD, strategy, max_extent=12.0, limit=40)
    assert len(stopped) == 40
    assert_partition(stopped, len(pts))
    assert max(c.extent for c in stopped) > 12.0  # out of reach, and it shows
    same = make_clumps(pts, OVERHEAD, strategy, max_extent=12.0, limit=len(full))
    assert [c.members for c in same] == [c.members for c in full]
    with pytest.raises(ValueError):
        make_clumps(pts, OVERHEAD, strategy, max_extent=12.0, limit=0)


def test_max_extent_for_density():
    assert max_extent_for_density(1024, 48.0) == pytest.approx(1024 / 48)
    with pytest.raises(ValueError):
        max_extent_for_density(0, 48.0)
    with pytest.raises(ValueError):
        max_extent_for_density(1024, 0.0)


@pytest.mark.parametrize("strategy", STRATEGIES)
@pytest.mark.parametrize("count", [1, 2, 3, 7, 50, 64])
def test_count_override_is_exact(strategy, count):
    pts = random_town(64, seed=4)
    # max_extent would allow one clump; count must win.
    clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=1e6, count=count)
    assert len(clumps) == count
    assert_partition(clumps, 64)


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_count_above_object_count_gives_one_clump_per_object(strategy):
    pts = random_town(5, seed=5)
    clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=1.0, count=12)
    assert [c.members for c in clumps] == [(i,) for i in range(5)]


@pytest.mark.parametrize("bad", [0, -3])
def test_count_below_one_is_rejected(bad):
    with pytest.raises(ValueError, match="count"):
        make_clumps(random_town(5, seed=6), OVERHEAD, "world", max_extent=1.0, count=bad)


def test_unknown_strategy_names_the_valid_ones():
    with pytest.raises(ValueError, match="world.*light"):
        make_clumps(random_town(5, seed=7), OVERHEAD, "octree", max_extent=1.0)


def test_world_splits_at_median_of_widest_axis():
    # Centres spread 0..90 along z, 0..5 along x: the first split must cut z at the median.
    rng = np.random.default_rng(8)
    zs = rng.permutation(np.arange(10) * 10.0)
    pts = [box([0.5 * i, 0.0, z]) for i, z in enumerate(zs)]
    clumps = make_clumps(pts, OVERHEAD, "world", max_extent=1e6, count=2)
    near = frozenset(int(i) for i in np.flatnonzero(zs < 45.0))
    far = frozenset(range(10)) - near
    assert {frozenset(c.members) for c in clumps} == {near, far}


def test_light_space_clumps_overlap_less_under_a_low_diagonal_sun():
    # Two rows of tall posts running along the diagonal x = z, 28 m apart, under a low sun shining
    # along the same diagonal. World space splits at the median x (x and z spread equally), which
    # cuts both rows in two: a near and a far group whose long shadows cover the same part of the
    # map. Light space sees two separate strips, one per row, and splits between them.
    along = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
    across = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)
    pts = [
        box(6.0 * t * along + side * 14.0 * across, [2.0, 8.0, 2.0])
        for side in (-1.0, 1.0)
        for t in range(10)
    ]
    fp = directional_footprint(light_rot_towards([1.0, -0.25, 1.0]))
    world = make_clumps(pts, fp, "world", max_extent=1e6, count=2)
    light = make_clumps(pts, fp, "light", max_extent=1e6, count=2)
    assert [c.members for c in light] == [tuple(range(10)), tuple(range(10, 20))]
    assert footprint_overlap(light) == 0.0
    assert footprint_overlap(world) > 0.3


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_deterministic(strategy):
    fp = directional_footprint(light_rot_towards([0.4, -1.0, -0.7]))
    a = make_clumps(random_town(500, seed=9), fp, strategy, max_extent=25.0)
    b = make_clumps(random_town(500, seed=9), fp, strategy, max_extent=25.0)
    assert [c.members for c in a] == [c.members for c in b]
    for ca, cb in zip(a, b, strict=True):
        np.testing.assert_array_equal(ca.rect, cb.rect)


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_no_objects(strategy):
    assert make_clumps([], OVERHEAD, strategy, max_extent=10.0) == []


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_one_object(strategy):
    pts = [box([3.0, 0.0, -2.0], 50.0)]
    for count in (None, 1, 4):
        clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=10.0, count=count)
        assert [c.members for c in clumps] == [(0,)]
        np.testing.assert_allclose(clumps[0].rect, [-22.0, -23.0, 28.0, 27.0])


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_objects_stacked_in_one_place_still_split(strategy):
    # Identical 1 m boxes: no spread to split on, so the split falls back to index order.
    pts = [box([5.0, 1.0, 5.0]) for _ in range(50)]
    clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=0.5)
    assert [c.members for c in clumps] == [(i,) for i in range(50)]
    clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=0.5, count=4)
    assert sorted(len(c.members) for c in clumps) == [12, 12, 13, 13]
    assert_partition(clumps, 50)


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_point_objects_at_one_place_fit_in_one_clump(strategy):
    pts = [np.zeros((1, 3)) for _ in range(20)]
    clumps = make_clumps(pts, OVERHEAD, strategy, max_extent=1.0)
    assert [c.members for c in clumps] == [tuple(range(20))]
    assert footprint_overlap(clumps) == 0.0


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_spot_light_footprint_function(strategy):
    # A spot light at the origin looking down -y: footprint = angles (radians) off its axis.
    def angles(points: np.ndarray) -> np.ndarray:
        depth = -points[:, 1]
        return np.stack([np.arctan2(points[:, 0], depth), np.arctan2(points[:, 2], depth)], axis=1)

    pts = [box([x, -10.0, z]) for x in (-8.0, -4.0, 0.0, 4.0, 8.0) for z in (-8.0, 0.0, 8.0)]
    clumps = make_clumps(pts, angles, strategy, max_extent=0.5)
    assert_partition(clumps, len(pts))
    for c in clumps:
        assert c.extent <= 0.5 or len(c.members) == 1
        expected = rect_of(np.concatenate([pts[i] for i in c.members]), angles)
        np.testing.assert_allclose(c.rect, expected, atol=1e-12)


def test_directional_footprint_projects_onto_light_xy():
    rot = light_rot_towards([1.0, -2.0, 0.5])
    fp = directional_footprint(rot)
    p = np.array([[1.0, 2.0, 3.0], [-4.0, 0.5, 7.0]])
    np.testing.assert_allclose(fp(p), [[rot[0] @ q, rot[1] @ q] for q in p])
    with pytest.raises(ValueError):
        directional_footprint(np.ones((3, 3)))


def test_bad_points_are_rejected():
    with pytest.raises(ValueError, match="object 1"):
        make_clumps([box([0, 0, 0]), np.zeros((0, 3))], OVERHEAD, "world", max_extent=1.0)
    with pytest.raises(ValueError, match="object 0"):
        make_clumps([np.zeros((4, 2))], OVERHEAD, "light", max_extent=1.0)


def test_footprint_overlap_known_values():
    def clump(rect):
        return Clump(members=(0,), rect=np.asarray(rect, dtype=np.float64))

    assert footprint_overlap([]) == 0.0
    assert footprint_overlap([clump([0, 0, 1, 1])]) == 0.0
    # Touching edges do not overlap.
    assert footprint_overlap([clump([0, 0, 1, 1]), clump([1, 0, 2, 1])]) == 0.0
    # Two 2x2 squares sharing a 1x1 corner: 1 / 8.
    assert footprint_overlap([clump([0, 0, 2, 2]), clump([1, 1, 3, 3])]) == pytest.approx(1 / 8)
    # Three identical unit squares: 3 overlapping pairs of area 1 over total area 3.
    assert footprint_overlap([clump([0, 0, 1, 1])] * 3) == pytest.approx(1.0)


def test_footprint_overlap_matches_brute_force():
    rng = np.random.default_rng(10)
    lo = rng.uniform(0.0, 50.0, (300, 2))
    rects = np.concatenate([lo, lo + rng.uniform(0.0, 8.0, (300, 2))], axis=1)
    clumps = [Clump(members=(i,), rect=r) for i, r in enumerate(rects)]
    overlap = 0.0
    for a, b in itertools.combinations(rects, 2):
        w = min(a[2], b[2]) - max(a[0], b[0])
        h = min(a[3], b[3]) - max(a[1], b[1])
        overlap += max(w, 0.0) * max(h, 0.0)
    total = np.sum((rects[:, 2] - rects[:, 0]) * (rects[:, 3] - rects[:, 1]))
    assert overlap > 0.0
    assert footprint_overlap(clumps) == pytest.approx(overlap / total, rel=1e-12)
