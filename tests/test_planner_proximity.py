"""The search's proximity shortcut (navstack.planner.proximity): same answers as the full scan.

References: the occupancy mask against a brute-force dilation in numpy; the snapshot of
:func:`point_index` against the map's own lists; ``nearest_in`` and ``distance_below`` against
:func:`navstack.planner.map.nearest_distance` over the map's lists (bit for bit) and against the
brute-force nearest point, on random maps with points inside and beyond the map box, removed points and
radii on both sides of the mask's reach.
"""

from __future__ import annotations

import numpy as np
import pytest

from navstack.planner.map import MapConfig, SensedMap, nearest_distance
from navstack.planner.proximity import (
    ADJACENT,
    REACH,
    distance_below,
    nearest_in,
    occupied_near,
    point_index,
    sets_closer_than,
)


def _brute_mask(head: np.ndarray, reach: int = REACH) -> np.ndarray:
    occ = head >= 0
    out = np.zeros_like(occ)
    for i, j, k in np.argwhere(occ):
        out[max(i - reach, 0): i + reach + 1, max(j - reach, 0): j + reach + 1, max(k - reach, 0): k + reach + 1] = True
    return out


@pytest.mark.parametrize("seed", range(4))
def test_occupied_near_is_the_dilation_of_the_filled_buckets(seed):
    rng = np.random.default_rng(seed)
    head = np.where(rng.random((9, 7, 11)) < 0.02 * (seed + 1), 5, -1).astype(np.int64)
    head[0, 0, 0] = 3 if seed % 2 else -1  # a corner bucket
    occ = occupied_near(head >= 0)
    np.testing.assert_array_equal(occ & 1 != 0, _brute_mask(head))
    np.testing.assert_array_equal(occ & ADJACENT != 0, _brute_mask(head, 1))
    assert set(np.unique(occ)) <= {0, 1, 1 + ADJACENT}  # the neighbourhood's bit only within REACH's


def test_occupied_near_of_an_empty_map_is_empty():
    assert not occupied_near(np.zeros((4, 5, 6), dtype=np.bool_)).any()


def _random_map(seed: int) -> SensedMap:
    rng = np.random.default_rng(seed)
    smap = SensedMap([0.0, 0.0, 0.0], [0.5, 0.4, 0.3], MapConfig(margin=0.1))
    centres = rng.uniform(-0.3, 0.8, size=(6, 3))  # clusters, some beyond the box (edge buckets hold those)
    pts = np.concatenate([c + 0.02 * rng.normal(size=(40, 3)) for c in centres])
    smap.add_points(pts)
    smap._alive[: smap.n_slots: 7] = False  # removed points stay in their buckets' lists
    return smap


@pytest.mark.parametrize("seed", range(3))
def test_point_index_holds_each_live_point_once_in_its_bucket(seed):
    smap = _random_map(seed)
    occ, start, S, origin, bucket, dims = point_index(smap)
    live_buckets = np.zeros(smap.head.shape, dtype=bool)  # the buckets of the live points (not removed ones)
    cells = np.clip(np.floor((smap.points - origin) / bucket).astype(int), 0, dims - 1)
    live_buckets[tuple(cells.T)] = True
    np.testing.assert_array_equal(occ, occupied_near(live_buckets))
    assert start[0] == 0 and np.all(np.diff(start) >= 0) and start[-1] == len(S)
    live = smap.points
    assert len(live) < smap.n_slots  # removed points are left out
    np.testing.assert_array_equal(np.unique(S, axis=0), np.unique(live, axis=0))
    assert len(S) == len(live)
    cells = np.clip(np.floor((S - origin) / bucket).astype(int), 0, dims - 1)  # clipped: beyond the box, edges
    flat = np.ravel_multi_index(tuple(cells.T), tuple(dims))
    np.testing.assert_array_equal(flat, np.repeat(np.arange(len(start) - 1), np.diff(start)))


@pytest.mark.parametrize("seed", range(3))
def test_distance_below_and_nearest_in_equal_the_map_lists_scan_bit_for_bit(seed):
    smap = _random_map(seed)
    arrays = smap.arrays()
    index = point_index(smap)
    occ = index[0]
    rng = np.random.default_rng(100 + seed)
    live = smap.points
    away = rng.normal(size=(600, 3))
    away *= rng.uniform(0.07, 0.12, size=(600, 1)) / np.linalg.norm(away, axis=1, keepdims=True)
    queries = np.concatenate([rng.uniform(-0.5, 1.0, size=(1500, 3)),
                              live[rng.integers(0, len(live), 300)] + 0.03 * rng.normal(size=(300, 3)),
                              live[rng.integers(0, len(live), 600)] + away])  # at the mask's edge
    bucket = smap.config.bucket
    cells = np.clip(np.floor((queries - smap.origin) / bucket).astype(int), 0, smap.bucket_dims - 1)
    empty = occ[tuple(cells.T)] == 0
    assert 200 < empty.sum() < len(queries) - 200  # both ways are exercised
    below = 0
    for r in (0.01, 0.035, bucket, 0.075, REACH * bucket, REACH * bucket + 1e-3, 0.1, 0.115, 0.2):
        for q in queries:
            fast = distance_below(q[0], q[1], q[2], r, *index)
            full = nearest_distance(q[0], q[1], q[2], r, *arrays)
            assert fast == full, (q, r, fast, full)
            scan = nearest_in(q[0], q[1], q[2], r, *index[1:])  # the snapshot's scan, without the mask
            assert scan == full, (q, r, scan, full)
            below += scan < r
            true = float(np.min(np.linalg.norm(live - q, axis=1)))
            assert fast == pytest.approx(min(true, r), abs=1e-12) or true >= r
    assert below > 1000


def _segment_distances(live: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Each point's exact distance to the segment a-b, in numpy (an independent reference)."""
    d = b - a
    dd = float(d @ d)
    u = np.clip((live - a) @ d / dd, 0.0, 1.0) if dd > 0 else np.zeros(len(live))
    return np.linalg.norm(live - (a + u[:, None] * d), axis=1)


@pytest.mark.parametrize("seed", range(3))
def test_segment_distance_below_is_the_exact_distance_to_the_segment(seed):
    """Against every live point's distance to the segment computed in numpy: the nearest below ``r`` (else
    ``r``), and with ``first`` an answer below ``r`` exactly when some point is nearer than ``r``; segments near the
    clusters and anywhere, 0 to 0.3 m long, ``r`` either side of a bucket's width (the neighbourhood's size)."""
    from navstack.planner.proximity import segment_distance_below

    smap = _random_map(seed)
    index = point_index(smap)
    rng = np.random.default_rng(300 + seed)
    live = smap.points
    bucket = smap.config.bucket
    outcomes = {True: 0, False: 0}
    for r in (0.01, 0.028, 0.035, 0.038, bucket - 2e-6, bucket, 0.05, 0.079, 0.09):
        for t in range(200):
            a = (live[rng.integers(0, len(live))] + 0.06 * rng.normal(size=3) if t % 3
                 else rng.uniform(-0.5, 1.0, size=3))  # near the clusters, or anywhere (also beyond the box)
            d = rng.normal(size=3)
            b = a + (rng.uniform(0.0, 0.3) if t % 10 else 0.0) * d / np.linalg.norm(d)
            true = float(_segment_distances(live, a, b).min())
            got = segment_distance_below(*a, *b, r, False, *index)
            assert got == pytest.approx(min(true, r), abs=1e-12), (a, b, r, got, true)
            if abs(true - r) > 1e-9:
                near = segment_distance_below(*a, *b, r, True, *index) < r
                assert near == (true < r), (a, b, r, true)
                outcomes[near] += 1
    assert min(outcomes.values()) > 300, outcomes  # both answers, many times


@pytest.mark.parametrize("seed", range(3))
def test_distances_below_is_distance_below_bit_for_bit(seed):
    from navstack.planner.proximity import distances_below

    smap = _random_map(seed)
    index = point_index(smap)
    rng = np.random.default_rng(300 + seed)
    live = smap.points
    bucket = smap.config.bucket
    out = np.empty(8)
    below = 0
    for r in (0.01, 0.035, 0.075, REACH * bucket, REACH * bucket + 1e-3, 0.1):
        for t in range(250):
            p = live[rng.integers(0, len(live))] + 0.05 * rng.normal(size=3) if t % 4 else rng.uniform(-0.5, 1, 3)
            d = rng.normal(size=3)
            n = int(rng.integers(1, 9))
            xs = p + np.outer(np.arange(n), 0.01 * d / np.linalg.norm(d))  # a primitive's samples, 1 cm apart
            distances_below(xs, n, r, out, *index)
            want = [distance_below(*x, r, *index) for x in xs]
            assert out[:n].tolist() == want, (xs, r)
            below += sum(w < r for w in want)
    assert below > 500


def _plate_map(seed: int) -> SensedMap:
    """Sensed-like surfaces: three tilted plates of points 1 cm apart with shadows behind them, one reaching
    beyond the map box; the columns' runs are long (the search's narrowing of a run is taken)."""
    rng = np.random.default_rng(seed)
    smap = SensedMap([0.0, 0.0, 0.0], [0.5, 0.4, 0.3], MapConfig(margin=0.1))
    g = np.arange(-0.15, 0.15, 0.01)
    for c in (rng.uniform(0.0, 0.5, 3), rng.uniform(0.0, 0.5, 3), np.array([0.62, 0.2, 0.15])):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        pts = c + g[:, None, None] * u + g[None, :, None] * w
        pts = pts.reshape(-1, 3) + 0.002 * rng.normal(size=(len(g) ** 2, 3))
        smap.add_points(pts)
        smap.add_points(pts - 0.015 * n, shadow=True)
    return smap


@pytest.mark.parametrize("seed", range(2))
def test_distances_below_is_distance_below_bit_for_bit_on_dense_surfaces(seed):
    from navstack.planner.proximity import _PRUNE_RUN, distances_below

    smap = _plate_map(seed)
    index = point_index(smap)
    start = index[1]
    runs = start[5:] - start[:-5]  # points in five buckets of one column (or straddling two)
    assert runs.max() > 4 * _PRUNE_RUN  # the narrowing is taken
    rng = np.random.default_rng(400 + seed)
    live = smap.points
    out = np.empty(8)
    below = 0
    for r in (0.035, 0.075, 0.08):
        for _ in range(300):
            p = live[rng.integers(0, len(live))] + 0.04 * rng.normal(size=3)
            d = rng.normal(size=3)
            n = int(rng.integers(1, 9))
            xs = p + np.outer(np.arange(n), 0.01 * d / np.linalg.norm(d))
            distances_below(xs, n, r, out, *index)
            want = [distance_below(*x, r, *index) for x in xs]
            assert out[:n].tolist() == want, (xs, r)
            below += sum(w < r for w in want)
    assert below > 1500


@pytest.mark.parametrize("axis", [0, 1])
def test_distances_below_finds_a_point_on_a_bucket_face_just_inside_r(axis):
    """A point on a bucket's face, the samples in the column beside it at its height: its distance is the
    column's horizontal gap itself, and with ``r`` 0.1 um beyond it, it must be found (a column is passed over
    only when its gap, less a slack, is no nearer than a sample's best), bit for bit as point by point."""
    from navstack.planner.proximity import distances_below

    smap = SensedMap([0.0, 0.0, 0.0], [0.5, 0.4, 0.3], MapConfig(margin=0.1))
    origin, bucket = point_index(smap)[3], smap.config.bucket
    face = np.array([0.2, 0.2, 0.12])
    face[axis] = origin[axis] + 7 * bucket  # exactly on the face between bucket rows 6 and 7
    smap.add_points(face[None])
    index = point_index(smap)
    live = smap.points[0]
    out = np.empty(3)
    for gap in (0.003, 0.011, 0.029, 0.047, 0.061):
        xs = np.repeat(live[None], 3, axis=0)
        xs[:, axis] -= gap  # in row 6, the point's column's neighbour, at the point's height
        xs[1:, 1 - axis] += (0.004, -0.006)
        true = np.linalg.norm(xs - live, axis=1)
        for r in (true[0] + 1e-7, true[0] - 1e-7):
            distances_below(xs, 3, r, out, *index)
            want = [distance_below(*x, r, *index) for x in xs]
            assert out.tolist() == want, (gap, r)
            assert (out[0] < r) == (true[0] < r) and (out[0] == pytest.approx(true[0], abs=1e-12) or true[0] >= r)


def test_point_index_is_shared_at_one_revision_and_renewed_by_every_change():
    smap = SensedMap([0.0, 0.0, 0.0], [0.5, 0.4, 0.3], MapConfig(margin=0.1))
    smap.add_points(np.array([[0.1, 0.1, 0.1], [0.3, 0.2, 0.1]]))
    first = point_index(smap)
    assert point_index(smap) is first  # no change: the same snapshot
    smap.add_points(np.array([[0.1, 0.1, 0.1004]]))  # a sub-millimetre move: `version` stays, the snapshot not
    moved = point_index(smap)
    assert moved is not first and not np.array_equal(moved[2], first[2])
    smap.update(np.array([[0.0, 0.2, 0.1]]), np.array([[1.0, 0.0, 0.0]]), np.array([0.0]), np.array([0.25]),
                np.array([True]), np.array([True]))
    hit = point_index(smap)
    assert hit is not moved and len(hit[2]) > len(moved[2])
    assert np.any(np.all(np.abs(hit[2] - [0.25, 0.2, 0.1]) < 1e-12, axis=1))  # the ray's hit, with its shadows
    np.testing.assert_array_equal(hit[2], point_index(smap)[2])


def test_sets_closer_than_is_numpys_smallest_pairwise_distance_against_the_threshold():
    rng = np.random.default_rng(3)
    for _ in range(300):
        a = rng.normal(scale=0.1, size=(int(rng.integers(0, 12)), 3))
        b = rng.normal(scale=0.1, size=(int(rng.integers(0, 30)), 3))[:: int(rng.integers(1, 4))]  # strided too
        if len(a) and len(b):
            d = float(np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2).min()))
            for r in (d, np.nextafter(d, np.inf), 0.5 * d + 0.01):
                assert sets_closer_than(a, b, r) == (d < r)
        else:
            assert not sets_closer_than(a, b, 1.0)  # an empty set is near nothing


def _one_point_map() -> SensedMap:
    return SensedMap([0.0, 0.0, 0.0], [0.8, 0.6, 0.6], MapConfig(margin=0.1))


def _one_point_index(p):
    """A map holding the one point ``p`` [m], and its snapshot for the kernels."""
    smap = _one_point_map()
    smap.add_points(np.array([p]))
    return smap, point_index(smap)


def _before_a_bucket_face() -> np.ndarray:
    """A point [m] of those maps a millimetre before the right face (+x) of its bucket."""
    smap = _one_point_map()
    return np.array([smap.origin[0] + 8 * smap.config.bucket - 0.001, 0.3, 0.3])


def _bucket_of(x, index):
    origin, bucket, dims = index[3], index[4], index[5]
    return tuple(np.clip(np.floor((np.asarray(x) - origin) / bucket).astype(int), 0, dims - 1))


def test_distances_below_finds_a_point_beyond_the_masks_reach():
    """``r`` beyond ``REACH`` buckets: samples whose buckets the mask shows quiet may still have a point within
    ``r``, so they are scanned all the same."""
    from navstack.planner.proximity import distances_below

    p_edge = _before_a_bucket_face()
    smap, index = _one_point_index(p_edge)
    bucket = smap.config.bucket
    r = 0.1
    xs = p_edge + np.outer([0.085, 0.09, 0.095], [1.0, 0.0, 0.0])  # 3 buckets on: quiet, but nearer than r
    assert all(index[0][_bucket_of(x, index)] == 0 for x in xs) and r > REACH * bucket
    out = np.empty(3)
    distances_below(xs, 3, r, out, *index)
    np.testing.assert_allclose(out, [0.085, 0.09, 0.095], atol=1e-12)
    assert out.tolist() == [distance_below(*x, r, *index) for x in xs]


def test_segment_distance_below_scans_a_sample_two_buckets_from_its_point():
    """A neighbourhood of ``REACH`` buckets: a point two buckets from the sample's (the mask's first bit only, not
    the adjacent one) lies within ``r`` and is found, for a segment of no length as for a short one."""
    from navstack.planner.proximity import segment_distance_below

    a = _before_a_bucket_face()
    q = a + [0.065, 0.0, 0.0]
    smap, index = _one_point_index(q)
    assert index[0][_bucket_of(a, index)] == 1  # within REACH buckets, not adjacent
    r = 0.07
    for b in (a, a + [0.0, 0.01, 0.0]):
        want = float(_segment_distances(np.array([q]), a, b).min())
        assert want < r
        assert segment_distance_below(*a, *b, r, False, *index) == pytest.approx(want, abs=1e-12)


@pytest.mark.parametrize("near_end", [0, 1])
def test_segment_distance_below_finds_a_point_beside_either_half_alone(near_end):
    """A 20 cm segment with a point beside one end only: the other half's middle is quiet, the early answer
    (both halves quiet) is not taken, and the point's distance is found."""
    from navstack.planner.proximity import segment_distance_below

    a, b = np.array([0.2, 0.3, 0.3]), np.array([0.4, 0.3, 0.3])
    q = (b if near_end else a) + [(-0.01 if near_end else 0.01), 0.015, 0.0]
    smap, index = _one_point_index(q)
    quiet_middle = a + (0.25 if near_end else 0.75) * (b - a)
    assert index[0][_bucket_of(quiet_middle, index)] == 0
    r = 0.02
    assert 0.25 * 0.2 + r < REACH * smap.config.bucket  # the early answer's condition holds
    assert segment_distance_below(*a, *b, r, False, *index) == pytest.approx(0.015, abs=1e-12)
    assert segment_distance_below(*a, *b, r, True, *index) == pytest.approx(0.015, abs=1e-12)
