"""The planner's sensed map (navstack.planner.map): voxel merging, exact distances, ray fusion, shadow points,
clearing (``forget_moved``), sensing motion (``detect_motion``).

References are independent of the kernels: brute-force distances over the stored points, cell sets
from fine sampling of each ray, and the map's documented rules written out in the tests.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navstack.planner.map import MapConfig, SensedMap

CFG = MapConfig()
PLAIN = MapConfig(shadow_depths=())  # hits only: no shadow points behind them
# one clean pass of a ray removes a point
ONE_PASS = MapConfig(shadow_depths=(), forget_moved=True, initial_evidence=1, max_evidence=1)
CLEARING = ONE_PASS
LO, HI = np.zeros(3), np.array([0.6, 0.4, 0.4])


def _map(config: MapConfig = CFG) -> SensedMap:
    return SensedMap(LO, HI, config)


def _voxel_cloud(rng: np.random.Generator, n: int, lo=(-0.1, -0.1, -0.1), hi=(0.7, 0.5, 0.5)) -> np.ndarray:
    """``n`` points in distinct voxels (voxel centres +- 3 mm), so that none of them merge."""
    v = CFG.voxel
    lo_i = np.floor(np.asarray(lo) / v).astype(int)
    hi_i = np.floor(np.asarray(hi) / v).astype(int)
    keys = set()
    while len(keys) < n:
        keys.add(tuple(int(rng.integers(a, b)) for a, b in zip(lo_i, hi_i, strict=True)))
    centres = (np.array(sorted(keys)) + 0.5) * v
    return centres + rng.uniform(-0.003, 0.003, centres.shape)


def _brute(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    return np.sqrt(((queries[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)).min(axis=1)


def _sorted_rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


def _free_cells(smap: SensedMap) -> set[tuple[int, int, int]]:
    return {tuple(int(x) for x in c) for c in np.argwhere(smap.free != 0)}


def _cells_on(smap: SensedMap, origin, direction, s0: float, s1: float, fine: float = 1e-4):
    """Cells crossed by the segment [s0, s1) of a ray, with the length of ray inside each (fine sampling)."""
    s = np.arange(s0, s1, fine)
    pts = np.asarray(origin) + s[:, None] * np.asarray(direction)
    idx = np.floor((pts - smap.origin) / smap.config.free_cell).astype(int)
    cells, counts = np.unique(idx, axis=0, return_counts=True)
    return {tuple(int(x) for x in c): n * fine for c, n in zip(cells, counts, strict=True)}


# ---------------------------------------------------------------------------- voxel merging
def test_hits_in_one_voxel_merge_into_their_mean():
    smap = _map()
    base = np.array([0.305, 0.105, 0.205])  # a voxel centre: the samples stay in its 1 cm voxel
    rng = np.random.default_rng(0)
    pts = base + rng.uniform(-0.002, 0.002, (CFG.average, 3))
    for k in range(1, CFG.average + 1):
        smap.add_points(pts[k - 1 : k])
        assert smap.n_points == 1
        np.testing.assert_allclose(smap.points[0], pts[:k].mean(axis=0), rtol=0, atol=1e-12)


def test_beyond_average_samples_the_mean_runs_with_weight_one_over_average():
    smap = _map()
    base = np.array([0.305, 0.105, 0.205])
    rng = np.random.default_rng(1)
    pts = base + rng.uniform(-0.002, 0.002, (CFG.average + 5, 3))
    smap.add_points(pts[: CFG.average])
    for p in pts[CFG.average :]:
        before = smap.points[0]
        smap.add_points(p[None])
        np.testing.assert_allclose(smap.points[0], before + (p - before) / CFG.average, rtol=0, atol=1e-12)
    assert smap.n_points == 1


def test_hits_in_different_voxels_stay_separate_points():
    rng = np.random.default_rng(2)
    cloud = _voxel_cloud(rng, 500)
    smap = _map()
    smap.add_points(cloud)
    assert smap.n_points == smap.n_slots == 500
    np.testing.assert_array_equal(_sorted_rows(smap.points), _sorted_rows(cloud))
    # two hits 1 mm apart across a voxel boundary are two points, 1 mm apart within a voxel one
    smap2 = _map()
    smap2.add_points([[0.2995, 0.105, 0.105], [0.3005, 0.105, 0.105]])
    assert smap2.n_points == 2
    smap2.add_points([[0.3015, 0.105, 0.105]])
    assert smap2.n_points == 2


# ---------------------------------------------------------------------------- distance
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_distance_is_exact_below_the_bucket_size(seed):
    rng = np.random.default_rng(seed)
    cloud = _voxel_cloud(rng, 1500)
    smap = _map()
    smap.add_points(cloud)
    # queries: uniform in (and a little beyond) the map, and right next to the points
    q = np.vstack([rng.uniform(-0.2, 0.8, (1500, 3)),
                   cloud[rng.integers(0, len(cloud), 500)] + rng.normal(0.0, 0.02, (500, 3))])
    ref = _brute(cloud, q)
    got = np.array([smap.distance(x) for x in q])
    assert np.sum(ref < CFG.bucket) > 500  # most queries test the exact branch
    np.testing.assert_allclose(got, np.minimum(ref, CFG.bucket), rtol=0, atol=1e-12)
    # a smaller query radius caps the answer there; a larger one scans more buckets and stays exact
    got_r = np.array([smap.distance(x, r=0.03) for x in q[:300]])
    np.testing.assert_allclose(got_r, np.minimum(ref[:300], 0.03), rtol=0, atol=1e-12)
    got_big = np.array([smap.distance(x, r=1.0) for x in q[:300]])
    np.testing.assert_allclose(got_big, np.minimum(ref[:300], 1.0), rtol=0, atol=1e-12)


def test_distance_with_points_and_queries_outside_the_box():
    """Points beyond the mapped box are kept in its edge buckets: distances near them stay exact."""
    rng = np.random.default_rng(3)
    smap = _map()
    top = smap.origin + smap.free_dims * CFG.free_cell
    outside = np.vstack([
        smap.origin - rng.uniform(0.0, 0.3, (200, 3)),                     # below every face
        top + rng.uniform(0.0, 0.3, (200, 3)),                             # above every face
        np.column_stack([rng.uniform(0.0, 0.5, 200), rng.uniform(0.0, 0.3, 200),
                         top[2] + rng.uniform(0.0, 0.4, 200)]),            # beyond one face only
    ])
    assert not any(smap.inside(p) for p in outside)
    assert not any(smap.is_seen_free(p) for p in outside)
    smap.add_points(outside)
    pts = smap.points
    q = np.vstack([outside + rng.normal(0.0, 0.03, outside.shape), rng.uniform(-1.0, 1.5, (600, 3))])
    ref = _brute(pts, q)
    got = np.array([smap.distance(x) for x in q])
    assert np.sum(ref < CFG.bucket) > 400
    np.testing.assert_allclose(got, np.minimum(ref, CFG.bucket), rtol=0, atol=1e-12)


def test_an_empty_map_answers_the_query_radius():
    smap = _map()
    assert smap.n_points == 0 and smap.points.shape == (0, 3)
    assert smap.distance([0.3, 0.2, 0.2]) == pytest.approx(CFG.bucket)
    assert smap.distance([0.3, 0.2, 0.2], r=0.02) == pytest.approx(0.02)


def test_storage_grows_past_its_initial_capacity():
    rng = np.random.default_rng(4)
    cloud = _voxel_cloud(rng, 3000)  # > the 1024 initial slots: two doublings
    smap = _map()
    for chunk in np.array_split(cloud, 7):
        smap.add_points(chunk)
    assert smap.n_points == 3000
    q = rng.uniform(0.0, 0.6, (400, 3))
    np.testing.assert_allclose([smap.distance(x) for x in q], np.minimum(_brute(cloud, q), CFG.bucket),
                               rtol=0, atol=1e-12)



class _ReferenceMerge:
    """The merge rule of ``add_points`` written out in plain Python: dicts of voxel tuples, lists of slots."""

    def __init__(self, smap: SensedMap) -> None:
        self.smap = smap  # only its geometry and its seen-free cells are read
        self.P: list[np.ndarray] = []
        self.count: list[int] = []
        self.evidence: list[int] = []
        self.alive: list[bool] = []
        self.next: list[int] = []
        self.shadow: list[bool] = []
        self.head = np.full(tuple(smap.bucket_dims), -1, dtype=np.int64)
        self.voxels: dict[bool, dict[tuple[int, int, int], int]] = {False: {}, True: {}}
        self.version = 0
        self.new_points = np.empty((0, 3))
        self.put_back = self.refused_free = 0  # how often the rarer branches were taken

    def add(self, pts: np.ndarray, shadow: bool) -> None:
        cfg, origin = self.smap.config, self.smap.origin
        changed = []
        for p in pts:
            key = tuple(int(x) for x in np.floor((p - origin) / cfg.voxel))
            idx = self.voxels[shadow].get(key)
            if shadow and (idx is not None or self.smap.is_seen_free(p)):
                self.refused_free += idx is None
                continue  # a shadow is placed once, and never in a cell seen free
            if idx is not None and self.alive[idx]:  # one more sample of a live point
                c = min(self.count[idx] + 1, cfg.average)
                self.count[idx] = c
                self.evidence[idx] = min(self.evidence[idx] + 1, cfg.max_evidence)
                step = (p - self.P[idx]) / c
                self.P[idx] = self.P[idx] + step
                if step[0] * step[0] + step[1] * step[1] + step[2] * step[2] > 1e-6:
                    changed.append(self.P[idx])
                continue
            if idx is None:  # a new voxel: a new slot at the head of its bucket's list
                idx = len(self.P)
                self.voxels[shadow][key] = idx
                b = tuple(np.clip(np.floor((p - origin) / cfg.bucket).astype(int), 0, self.smap.bucket_dims - 1))
                self.P.append(p)
                self.count.append(0)
                self.evidence.append(0)
                self.alive.append(False)
                self.next.append(int(self.head[b]))
                self.shadow.append(shadow)
                self.head[b] = idx
            else:
                self.put_back += 1
            self.P[idx] = p.copy()  # a new point, or a removed one put back
            self.count[idx] = 1
            self.evidence[idx] = cfg.initial_evidence
            self.alive[idx] = True
            changed.append(p)
        if changed:
            self.version += 1
            self.new_points = np.vstack([self.new_points, np.array(changed)])


def test_add_points_matches_a_plain_python_merge_exactly():
    """Random batches (points in and far outside the box, repeated voxels, shadows, cells seen free, removed
    points put back, storage growing inside a batch): every array the kernels read, the version and the new
    points equal those of the rule written out in Python, bit for bit."""
    rng = np.random.default_rng(11)
    cfg = MapConfig(average=3, initial_evidence=2, max_evidence=4)
    smap = _map(cfg)
    ref = _ReferenceMerge(smap)
    top = smap.origin + smap.free_dims * cfg.free_cell
    pool = rng.uniform(smap.origin - 0.5, top + 0.5, (2500, 3))  # a fifth of them outside the box
    for call in range(90):
        smap.mark_free(pool[rng.integers(0, pool.shape[0])], 0.15)  # no shadows there any more
        if call % 9 == 8:
            n = smap.n_slots
            kill = rng.choice(n, n // 20, replace=False)  # forgotten points (as a clean pass removes them)
            smap._alive[kill] = False
            for q in kill:
                ref.alive[q] = False
        noise = rng.choice([0.0005, 0.004, 0.012])  # within a voxel, a few mm, into the next voxels
        pts = pool[rng.integers(0, pool.shape[0], int(rng.integers(1, 160)))]
        pts = pts + rng.normal(0.0, noise, pts.shape)
        shadow = bool(rng.random() < 0.35)
        smap.add_points(pts, shadow=shadow)
        ref.add(pts, shadow)
        n = len(ref.P)
        assert smap.n_slots == n and smap.version == ref.version
        np.testing.assert_array_equal(smap._P[:n], np.array(ref.P).reshape(-1, 3))
        np.testing.assert_array_equal(smap._count[:n], ref.count)
        np.testing.assert_array_equal(smap._evidence[:n], ref.evidence)
        np.testing.assert_array_equal(smap._alive[:n], ref.alive)
        np.testing.assert_array_equal(smap._next[:n], ref.next)
        np.testing.assert_array_equal(smap._shadow[:n], ref.shadow)
        np.testing.assert_array_equal(smap.head, ref.head)
        np.testing.assert_array_equal(smap.new_points, ref.new_points)
    # the sequence went through every branch
    outside = ~np.array([smap.inside(p) for p in ref.P])
    assert smap.n_slots > 2048 and outside.sum() > 100 and sum(ref.shadow) > 300
    assert ref.put_back > 10 and ref.refused_free > 10
    assert max(ref.count) == cfg.average and max(ref.evidence) == cfg.max_evidence


def test_add_points_rejects_points_it_cannot_key():
    smap = _map()
    for bad in ([np.nan, 0.1, 0.1], [0.1, np.inf, 0.1], [0.1, 0.1, 1e5]):
        with pytest.raises(ValueError, match="not finite or lies more than"):
            smap.add_points([[0.1, 0.1, 0.1], bad])
    assert smap.n_slots == 0 and smap.version == 0  # nothing merged from a batch that was refused

# ---------------------------------------------------------------------------- update: hits, misses, dropouts
O = np.array([0.1, 0.21, 0.19])
X = np.array([1.0, 0.0, 0.0])
DIAG = np.array([0.8, 0.5, 0.3]) / np.linalg.norm([0.8, 0.5, 0.3])


def test_a_hit_marks_free_space_up_to_the_backoff_and_adds_its_point():
    smap = _map()
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    np.testing.assert_allclose(smap.surface_points, [O + 0.3 * X], atol=1e-15)
    shadows = [O + (0.3 + depth) * X for depth in CFG.shadow_depths]  # behind the hit, along the ray
    assert len(shadows) == 3
    np.testing.assert_allclose(_sorted_rows(smap.points), _sorted_rows(np.array([O + 0.3 * X, *shadows])),
                               atol=1e-15)
    np.testing.assert_allclose(_sorted_rows(smap.new_points), _sorted_rows(smap.points), atol=1e-15)
    # an axis-aligned ray sampled every half cell marks exactly the cells it crosses before range - backoff
    expected = set(_cells_on(smap, O, X, 0.03, 0.3 - CFG.hit_backoff))
    assert _free_cells(smap) == expected
    assert smap.is_seen_free(O + 0.1 * X) and smap.is_seen_free(O + 0.25 * X)
    assert not smap.is_seen_free(O + 0.3 * X)  # the surface itself is not seen free
    assert not smap.is_seen_free(O + 0.01 * X)  # nor the blind zone before the ray's start


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("last", [False, True])
def test_a_ray_in_a_face_layer_of_the_grid_marks_its_cells_there(axis, last):
    """The first and the last layer of cells along each axis are cells like the others: a miss running inside
    one, along the next axis, marks exactly the cells it crosses (none dropped as outside the grid)."""
    smap = _map()
    cell, dims = smap.config.free_cell, smap.free_dims
    along = (axis + 1) % 3
    origin = smap.origin + 0.5 * cell * np.ones(3)  # the middle of cell (0, 0, 0) ...
    origin[axis] += (dims[axis] - 1) * cell if last else 0.0  # ... or of the last layer along ``axis``
    origin[(axis + 2) % 3] += 2 * cell
    direction = np.zeros(3)
    direction[along] = 1.0
    smap.update([origin], [direction], [0.0], [0.2], [False], [True])
    expected = set(_cells_on(smap, origin, direction, 0.0, 0.2))
    assert {c[axis] for c in expected} == {dims[axis] - 1 if last else 0}
    assert _free_cells(smap) == expected


def test_a_miss_marks_the_whole_ray_free_and_adds_nothing():
    smap = _map()
    smap.update([O], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 0 and len(smap.new_points) == 0 and smap.version == 0
    assert _free_cells(smap) == set(_cells_on(smap, O, X, 0.03, 0.4))


SKEWED = (np.array([-0.37, 0.11, 0.52]), np.array([0.3, 0.6, 1.0]), np.array([-0.2, 0.3, 0.7]))
"""A box whose corner differs in x, y and z (``LO`` is 0 in all three: each axis must use its own origin), and
a ray's origin in it."""


@pytest.mark.parametrize("box", [(LO, HI, O), SKEWED], ids=["corner-at-0", "skewed-corner"])
@pytest.mark.parametrize("hit", [True, False])
def test_an_oblique_ray_marks_only_cells_it_crosses_and_every_cell_it_crosses_for_half_a_cell(hit, box):
    lo, hi, o = box
    smap = SensedMap(lo, hi, CFG)
    rng_ = 0.33
    smap.update([o], [DIAG], [0.03], [rng_], [hit], [True])
    end = rng_ - CFG.hit_backoff if hit else rng_
    crossed = _cells_on(smap, o, DIAG, 0.03, end)
    free = _free_cells(smap)
    assert free <= set(crossed)
    # a sample every half cell cannot miss a cell the ray crosses for more than half a cell
    assert {c for c, length in crossed.items() if length > 0.5 * CFG.free_cell + 1e-3} <= free
    if hit:  # the hit where the ray ends, a surface at its distance
        np.testing.assert_allclose(smap.surface_points, [o + rng_ * DIAG], atol=1e-15)
        assert smap.distance(o + rng_ * DIAG + [0.0, 0.0, 0.01]) == pytest.approx(0.01, abs=1e-12)


def test_dropouts_and_uninformative_rays_change_nothing():
    smap = _map()
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    free0, pts0, v0 = smap.free.copy(), smap.points, smap.version
    # dropout (NaN range, informative or not), a coasting track (hit but not informative), a miss flagged
    # uninformative
    smap.update([O, O, O, O], [DIAG, DIAG, -X, [0.0, 1.0, 0.0]], [0.03] * 4, [np.nan, np.nan, 0.2, 0.4],
                [False, False, True, False], [True, False, False, False])
    np.testing.assert_array_equal(smap.free, free0)
    np.testing.assert_array_equal(smap.points, pts0)
    assert smap.version == v0 and len(smap.new_points) == 0


def test_update_fuses_many_rays_at_once_like_one_at_a_time():
    rng = np.random.default_rng(5)
    n = 40
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = np.tile([0.3, 0.2, 0.2], (n, 1))
    ranges = rng.uniform(0.1, 0.4, n)
    hit = rng.random(n) < 0.6
    informative = rng.random(n) < 0.9
    a, b = _map(), _map()  # shadows included: the batch places none where any of its rays passed
    a.update(origins, dirs, np.full(n, 0.03), ranges, hit, informative)
    for i in range(n):
        b.update(origins[i : i + 1], dirs[i : i + 1], [0.03], ranges[i : i + 1], hit[i : i + 1],
                 informative[i : i + 1])
    np.testing.assert_array_equal(a.free, b.free)
    np.testing.assert_allclose(_sorted_rows(a.points), _sorted_rows(b.points), atol=1e-15)
    expected = origins[hit & informative] + ranges[hit & informative, None] * dirs[hit & informative]
    np.testing.assert_allclose(_sorted_rows(a.surface_points), _sorted_rows(expected), atol=1e-12)
    assert a.n_points > len(expected)  # and some shadows


def test_update_merges_hits_and_shadows_in_one_pass_as_add_points_in_turn_would():
    """``update`` merges a reading's hits and then their shadows, depth by depth, in one compiled pass: the
    stored points, their slots, links, counts and flags, and the new points are those of ``add_points`` on
    the hits and then on each depth's shadows (only the version moves once, not once per call)."""
    rng = np.random.default_rng(11)
    hits = np.vstack([_voxel_cloud(rng, 60, lo=(0.05, 0.05, 0.05), hi=(0.55, 0.35, 0.35))] * 2)  # each twice
    hits[60:] += rng.uniform(-0.002, 0.002, (60, 3))  # ... the second time moved a little
    dirs = rng.normal(size=hits.shape)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    sets = [hits] + [hits + depth * dirs for depth in CFG.shadow_depths]
    sets.append(hits[:20] + 0.001)  # shadows landing in the hits' voxels: refused there
    a, b = _map(), _map()
    for m in (a, b):
        m.mark_free([0.3, 0.2, 0.2], 0.06)  # no shadow in a cell seen free
        m.add_points(hits[:10] + 0.3 * CFG.voxel)  # points already there
        m.new_points = np.empty((0, 3))
    a._merge(np.ascontiguousarray(np.vstack(sets)), len(hits))
    b.add_points(sets[0])
    for shadows in sets[1:]:
        b.add_points(shadows, shadow=True)
    assert a.n_slots == b.n_slots > len(hits) // 2
    n = a.n_slots
    for name in ("_P", "_count", "_evidence", "_alive", "_next", "_shadow"):
        np.testing.assert_array_equal(getattr(a, name)[:n], getattr(b, name)[:n], err_msg=name)
    np.testing.assert_array_equal(a.head, b.head)
    np.testing.assert_array_equal(a.new_points, b.new_points)
    assert a._voxels == b._voxels and a._shadow_voxels == b._shadow_voxels
    assert a._shadow[:n].any() and not a._shadow[:n].all()


# ---------------------------------------------------------------------------- shadow points
def test_shadows_are_kept_apart_from_surface_points_and_count_as_surfaces():
    smap = _map()
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    shadow = O + (0.3 + CFG.shadow_depths[0]) * X
    assert smap.distance(shadow + [0.0, 0.02, 0.0]) == pytest.approx(0.02, abs=1e-12)  # a surface to the planner
    # a hit on the shadow's voxel is a surface point of its own, beside the shadow
    smap.add_points([shadow + [0.001, 0.0, 0.0]])
    assert len(smap.surface_points) == 2 and smap.n_points == 5
    # the same hit again adds no shadows (each is placed once) and moves none
    before = _sorted_rows(smap.points)
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    np.testing.assert_array_equal(_sorted_rows(smap.points), before)


def test_no_shadow_where_a_ray_has_been():
    smap = _map()
    side = np.array([0.0, 1.0, 0.0])
    across = O + 0.33 * X - 0.1 * side  # a miss across the ray, through the cell of the 3 cm shadow
    smap.update([across], [side], [0.03], [0.2], [False], [True])
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    shadows = smap.points[np.linalg.norm(smap.points - (O + 0.3 * X), axis=1) > 1e-9]
    depths = sorted(round(float((p - O) @ X) - 0.3, 6) for p in shadows)
    assert depths == [0.015, 0.045]


def test_shadows_go_once_a_ray_sees_their_cell_free():
    smap = _map()
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    assert smap.n_points == 4
    v = smap.version
    side = np.array([0.0, 1.0, 0.0])
    smap.update([O + 0.33 * X - 0.1 * side], [side], [0.03], [0.2], [False], [True])  # across the 3 cm shadow
    assert smap.n_points == 3 and smap.version == v + 1
    assert smap.distance(O + 0.33 * X) > 0.01
    np.testing.assert_allclose(smap.surface_points, [O + 0.3 * X])  # the surface point stays
    smap.update([O], [X], [0.03], [0.3], [True], [True])  # and the shadow does not come back
    assert smap.n_points == 3


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_shadow_outside_the_box_is_not_purged_by_a_cell_inside(axis):
    """A shadow point just before the box's low face lies in no cell of the grid: a seen-free cell on the far
    side of the grid (where an index of -1 would wrap to) does not purge it, and an update keeps it."""
    smap = _map(PLAIN)
    cell = smap.config.free_cell
    p = smap.origin + (np.floor((O - smap.origin) / cell) + 0.5) * cell  # O's cell's centre ...
    p[axis] = smap.origin[axis] - 0.5 * cell  # ... moved to cell index -1 along ``axis``
    smap.add_points([p], shadow=True)
    far = p.copy()
    far[axis] = smap.origin[axis] + (smap.free_dims[axis] - 0.5) * cell  # the last layer, same cell otherwise
    smap.mark_free(far, 0.2 * cell)
    assert smap.is_seen_free(far) and not smap.is_seen_free(p)
    smap.update([O], [X], [0.03], [0.2], [False], [True])  # a reading elsewhere: shadows purged after it
    assert smap.n_points == 1


def test_without_shadow_depths_hits_add_only_their_points():
    smap = _map(PLAIN)
    smap.update([O], [X], [0.03], [0.3], [True], [True])
    np.testing.assert_allclose(smap.points, [O + 0.3 * X], atol=1e-15)


def test_without_forget_moved_rays_forget_nothing():
    smap = _map(MapConfig(shadow_depths=(), forget_moved=False))
    smap.add_points([[0.305, 0.205, 0.195]])
    for _ in range(10):
        smap.update([[0.105, 0.205, 0.195]], [X], [0.03], [0.4], [False], [True])  # straight through it
    assert smap.n_points == 1 and smap.version == 1


def test_evidence_counts_hits_up_and_clean_passes_down_once_per_ray():
    """A new point holds ``initial_evidence``, each further hit one more (up to ``max_evidence``), each ray
    passing cleanly through it one less, however many buckets of the ray's neighbourhood hold it."""
    evid = MapConfig(shadow_depths=(), forget_moved=True)  # evidence: initial 2, max 6 by default
    smap = _map(evid)
    assert (smap.config.initial_evidence, smap.config.max_evidence) == (2, 6)
    o = np.array([0.105, 0.205, 0.195])
    through = ([o - 0.0 * X], [X], [0.03], [0.4], [False], [True])
    smap.update([o], [X], [0.03], [0.2], [True], [True])  # first seen: evidence 2
    smap.update(*through)
    assert smap.n_points == 1
    smap.update(*through)
    assert smap.n_points == 0  # two clean passes
    # hit 8 times: evidence capped at 6, so 6 clean passes remove it and 5 do not
    smap = _map(evid)
    for _ in range(8):
        smap.update([o], [X], [0.03], [0.2], [True], [True])
    for _ in range(5):
        smap.update(*through)
    assert smap.n_points == 1
    # two rays through it in one update count twice; a ray that passes 5 mm beside it (> clear_radius) not
    smap.update([o + [0, 0.005, 0]], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 1
    smap.update([o, o], [X, X], [0.03, 0.03], [0.4, 0.4], [False, False], [True, True])
    assert smap.n_points == 0


# ---------------------------------------------------------------------------- clearing
P0 = np.array([0.305, 0.205, 0.195])


def _one_point_map() -> SensedMap:
    smap = _map(CLEARING)
    smap.add_points([P0])
    return smap


def test_a_ray_passing_through_a_point_removes_it():
    smap = _one_point_map()
    v = smap.version
    smap.update([P0 - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 0 and smap.version == v + 1
    assert smap.distance(P0) == pytest.approx(CFG.bucket)
    # a hit far behind the point clears it too (the point lies well before range - backoff - clear_backoff)
    smap = _one_point_map()
    smap.update([P0 - 0.2 * DIAG], [DIAG], [0.03], [0.35], [True], [True])
    assert not np.any(np.linalg.norm(smap.points - P0, axis=1) < 1e-9)
    assert smap.n_points == 1  # only the new hit (no shadows in this configuration)


def test_a_ray_ending_at_a_point_keeps_it():
    smap = _one_point_map()
    smap.update([P0 - 0.2 * X], [X], [0.03], [0.2], [True], [True])
    assert smap.n_points == 1
    np.testing.assert_allclose(smap.points[0], P0, atol=1e-12)
    # nor does a hit just beyond it, within hit_backoff + clear_backoff
    smap.update([P0 - 0.2 * X], [X], [0.03], [0.2 + CFG.hit_backoff + CFG.clear_backoff - 0.005], [True], [True])
    assert np.any(np.linalg.norm(smap.points - P0, axis=1) < 1e-9)


def test_a_ray_passing_beside_a_point_keeps_it():
    smap = _one_point_map()
    side = np.array([0.0, 1.0, 0.0])
    smap.update([P0 - 0.2 * X + (CFG.clear_radius + 0.001) * side], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 1
    smap.update([P0 - 0.2 * X + (CFG.clear_radius - 0.001) * side], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 0


def test_a_point_in_the_rays_blind_start_is_kept():
    smap = _one_point_map()
    smap.update([P0 - 0.02 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 1


def _clearing_reference(points, origin, direction, start, end):
    """Points the documented rule removes: on the ray strictly between start and end - clear_backoff,
    within clear_radius of its line."""
    w = points - origin
    a = w @ direction
    lateral = np.linalg.norm(w - a[:, None] * direction, axis=1)
    return (a > start) & (a < end - CFG.clear_backoff) & (lateral < CFG.clear_radius)


def test_clearing_matches_the_rule_for_random_rays_through_random_points():
    rng = np.random.default_rng(6)
    missed = []
    for _ in range(300):
        smap = _map(CLEARING)
        p = rng.uniform(0.0, 0.5, 3)
        smap.add_points([p])
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        origin = p - rng.uniform(0.1, 0.3) * d
        smap.update([origin], [d], [0.03], [0.4], [False], [True])
        assert _clearing_reference(np.array([p]), origin, d, 0.03, 0.4)[0]
        if smap.n_points:
            missed.append((p, origin, d))
    assert not missed, f"{len(missed)} of 300 points on a clean ray survived, e.g. {missed[0]}"


def test_a_ray_passing_just_inside_or_outside_the_clear_radius_of_a_point_beside_its_bucket():
    """The kernel scans only the buckets the segment, grown by the clear radius, touches.  A point 0.1-0.9 mm
    inside a face of its bucket, the ray 0.9 clear radius from it on the other side of that face (so in the
    next bucket all along): removed; 1.1 clear radius away: kept."""
    rng = np.random.default_rng(11)
    r = CLEARING.clear_radius
    wrong = []
    for trial in range(400):
        offset = (0.9 if trial % 2 == 0 else 1.1) * r
        smap = _map(CLEARING)
        axis, up = int(rng.integers(3)), bool(rng.integers(2))
        o = smap.origin  # the buckets' lattice starts there
        p = o + (np.floor((rng.uniform(0.1, 0.4, 3) - o) / CFG.bucket) + 0.5) * CFG.bucket  # a bucket's centre
        p[axis] += (1 if up else -1) * (CFG.bucket / 2 - rng.uniform(0.0001, 0.0009))  # near one face
        smap.add_points([p])
        normal = np.zeros(3)
        normal[axis] = 1.0 if up else -1.0
        d = rng.normal(size=3)
        d -= (d @ normal) * normal  # the ray runs along the face
        d /= np.linalg.norm(d)
        origin = p + offset * normal - rng.uniform(0.1, 0.25) * d
        smap.update([origin], [d], [0.03], [0.4], [False], [True])
        if smap.n_points != (0 if offset < r else 1):
            wrong.append((trial, p, d))
    assert not wrong, f"{len(wrong)} of 400 wrong, e.g. {wrong[0]}"


def test_a_ray_through_a_point_near_a_bucket_corner_removes_it():
    """The bug above, smallest case: the ray passes exactly through the point 0.2 m after its origin
    (well before its end), but clips the point's bucket (edges at -0.7 + 0.08 k: 0.1 here) for 3 mm."""
    smap = _map(CLEARING)
    p = np.array([0.099, 0.099, 0.25])
    smap.add_points([p])
    d = np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)
    smap.update([p - 0.2 * d], [d], [0.03], [0.4], [False], [True])
    assert smap.n_points == 0


def test_clearing_in_a_cloud_removes_only_what_the_rule_names_and_all_of_it_where_sampling_is_complete():
    """Many rays through a cloud.  No point the rule does not name is ever removed; every point it names
    on the clean stretch of the ray is removed (the kernel walks every bucket the ray crosses and its
    neighbours)."""
    rng = np.random.default_rng(7)
    smap = _map(CLEARING)
    cloud = _voxel_cloud(rng, 1500, lo=(0.05, 0.05, 0.05), hi=(0.55, 0.35, 0.35))
    inner = np.ones(len(cloud), dtype=bool)
    smap.add_points(cloud)
    alive = np.ones(len(cloud), dtype=bool)
    checked = 0
    for i in range(80):
        target = cloud[rng.choice(np.flatnonzero(inner))] if i % 2 == 0 else rng.uniform(0.1, 0.5, 3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        origin = target - rng.uniform(0.1, 0.25) * d
        rg = float(rng.uniform(0.35, 0.4))  # misses (free to rg): no new points to tell apart from the cloud
        named = _clearing_reference(cloud, origin, d, 0.03, rg)
        a = (cloud - origin) @ d
        sure = named & inner & (a > 0.03 + 1e-6) & (a < rg - CFG.clear_backoff - 1e-6)
        checked += int((sure & alive).sum())
        smap.update([origin], [d], [0.03], [rg], [False], [True])
        kept = {tuple(p) for p in smap.points}  # the cloud's points are stored exactly (distinct voxels)
        live = np.array([tuple(p) in kept for p in cloud])
        assert not np.any(live & ~alive), "a point came back"
        assert not np.any(alive & ~named & ~live), "a point the rule does not name was removed"
        assert not np.any(alive & sure & live), "a point on a clean stretch of the ray survived"
        alive &= live
    assert checked >= 20  # the complete case was exercised


def test_the_buckets_near_a_point_are_the_27_round_every_bucket_that_ever_held_one():
    """``_near``, which lets a clean pass skip a step of its walk, is the 3x3x3 dilation of the buckets that hold
    (or held) a point: checked against scipy's dilation after clouds inside and beyond the grid (clamped into
    its edge buckets), and after the points are cleared away (a bucket once near stays near)."""
    from scipy.ndimage import binary_dilation

    rng = np.random.default_rng(12)
    smap = _map(CLEARING)
    span = smap.origin + smap.bucket_dims * CFG.bucket
    for lo, hi in [((0.1, 0.1, 0.1), (0.2, 0.3, 0.2)), (smap.origin - 0.2, span + 0.2), (smap.origin, span)]:
        smap.add_points(_voxel_cloud(rng, 300, lo=lo, hi=hi))
        expected = binary_dilation(smap.head >= 0, structure=np.ones((3, 3, 3), dtype=bool))
        np.testing.assert_array_equal(smap._near.astype(bool), expected)
    before = smap._near.copy()
    smap.update(smap.points[:50] - 0.2 * X, np.tile(X, (50, 1)), np.full(50, 0.03), np.full(50, 0.4),
                np.zeros(50, dtype=bool), np.ones(50, dtype=bool))
    np.testing.assert_array_equal(smap._near, before)


@pytest.mark.parametrize("inward", [True, False])
def test_clearing_matches_the_rule_for_rays_crossing_the_grids_edge(inward):
    """A ray from outside the map's grid into it (its walk starts clamped to the edge buckets, where no step may
    be skipped), or from inside out of it, through a point inside near that edge: removed or kept as the rule
    says, a clear radius either side (as in the random-ray test above)."""
    rng = np.random.default_rng(13 if inward else 14)
    wrong = []
    outside = 0
    for trial in range(200):
        smap = _map(CLEARING)
        axis, high = int(rng.integers(3)), bool(rng.integers(2))
        edge = (smap.origin + smap.bucket_dims * CFG.bucket)[axis] if high else smap.origin[axis]
        p = rng.uniform(0.1, 0.3, 3)
        p[axis] = edge + (-1 if high else 1) * rng.uniform(0.005, 0.06)  # inside, near the edge
        smap.add_points([p])
        p = smap.points[0]  # as stored (the voxel's point)
        d = rng.normal(size=3)
        d[axis] = (-1 if high == inward else 1) * rng.uniform(0.5, 1.0) * np.linalg.norm(d)  # across the edge
        d /= np.linalg.norm(d)
        lateral = rng.normal(size=3)
        lateral -= (lateral @ d) * d
        lateral *= (0.9 if trial % 2 == 0 else 1.1) * CLEARING.clear_radius / np.linalg.norm(lateral)
        origin = p + lateral - rng.uniform(0.1, 0.25) * d
        start = (origin + 0.03 * d)[axis]
        outside += bool(start > edge if high else start < edge)
        smap.update([origin], [d], [0.03], [0.4], [False], [True])
        removed = _clearing_reference(np.array([p]), origin, d, 0.03, 0.4)[0]
        if smap.n_points != (0 if removed else 1):
            wrong.append((trial, p, origin, d))
    assert not wrong, f"{len(wrong)} of 200 wrong, e.g. {wrong[0]}"
    assert (outside >= 100) if inward else (outside == 0)  # the clamped start exercised (or not at all)


# ---------------------------------------------------------------------------- mark_free
@pytest.mark.parametrize(("centre", "radius"), [((0.303, 0.207, 0.191), 0.025), ((0.0, 0.0, 0.0), 0.061),
                                               ((-0.69, 0.1, 0.1), 0.05)])
def test_mark_free_marks_exactly_the_cells_whose_centres_are_within_the_radius(centre, radius):
    smap = _map()
    smap.mark_free(centre, radius)
    fc = CFG.free_cell
    idx = np.indices(tuple(smap.free_dims)).reshape(3, -1).T
    centres = smap.origin + (idx + 0.5) * fc
    dist = np.linalg.norm(centres - np.asarray(centre), axis=1)
    assert np.all(np.abs(dist - radius) > 1e-9)  # no cell on the boundary: the reference is unambiguous
    expected = {tuple(int(x) for x in c) for c in idx[dist <= radius]}
    assert expected and _free_cells(smap) == expected
    assert smap.n_points == 0 and smap.version == 0


# ---------------------------------------------------------------------------- version and new_points
def test_version_and_new_points_bookkeeping():
    smap = _map(CLEARING)
    assert smap.version == 0 and smap.new_points.shape == (0, 3)
    o = np.array([0.1, 0.105, 0.105])
    hit_at = 0.2013  # hit point (0.3013, 0.105, 0.105): in the voxel 0.30 <= x < 0.31
    smap.update([o], [X], [0.03], [hit_at], [True], [True])
    assert smap.version == 1
    np.testing.assert_allclose(smap.new_points, [o + hit_at * X])
    # the same hit again: nothing moved
    smap.update([o], [X], [0.03], [hit_at], [True], [True])
    assert smap.version == 1 and len(smap.new_points) == 0
    # a hit 1.2 mm on: the mean (3 samples) moves by 0.4 mm < 1 mm: the version stays
    smap.update([o], [X], [0.03], [hit_at + 0.0012], [True], [True])
    assert smap.version == 1 and len(smap.new_points) == 0
    assert smap.points[0, 0] == pytest.approx(o[0] + hit_at + 0.0004, abs=1e-12)
    # a hit 6 mm on (same voxel): the mean moves by (6 - 0.4) / 4 = 1.4 mm > 1 mm: new version, moved point
    smap.update([o], [X], [0.03], [hit_at + 0.006], [True], [True])
    assert smap.version == 2
    np.testing.assert_allclose(smap.new_points, smap.points)
    # a ray through it removes it: new version, no new points
    smap.update([o - 0.1 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 0 and smap.version == 3 and len(smap.new_points) == 0
    assert smap.n_slots == 1  # the slot stays, dead
    # the surface comes back: the dead voxel is reused as a fresh point (no old samples in its mean)
    smap.update([o], [X], [0.03], [hit_at + 0.005], [True], [True])
    assert smap.version == 4 and smap.n_slots == 1
    np.testing.assert_allclose(smap.points, [o + (hit_at + 0.005) * X], atol=1e-15)
    # two hits in one update: one version step, both points listed
    smap.update([o, o], [X, DIAG], [0.03, 0.03], [hit_at, 0.25], [True, True], [True, True])
    assert smap.version == 5 and len(smap.new_points) == 2


def test_add_points_without_update_accumulates_new_points():
    smap = _map(PLAIN)
    smap.add_points([[0.1, 0.1, 0.1]])
    smap.add_points([[0.2, 0.1, 0.1]])
    assert smap.version == 2 and len(smap.new_points) == 2
    smap.update([O], [X], [0.03], [0.4], [False], [True])  # an update starts a fresh list
    assert len(smap.new_points) == 0


# ---------------------------------------------------------------------------- configuration
@pytest.mark.parametrize(("name", "value"), [
    ("voxel", 0.0), ("voxel", -0.01), ("bucket", np.nan), ("free_cell", np.inf), ("margin", True),
    ("hit_backoff", "3 cm"), ("clear_radius", 0.0), ("clear_backoff", -1.0), ("sensed_clear_radius", 0.0),
    ("sensed_clear_slope", -0.1), ("sensed_clear_slope", 1.0), ("sensed_clear_slope", np.nan),
    ("average", 0), ("average", 2.0),
    ("average", True), ("shadow_depths", [0.01]), ("shadow_depths", (0.01, -0.02)), ("shadow_depths", (True,)),
    ("forget_moved", 1), ("detect_motion", 0), ("motion_contradictions", 0), ("motion_window", 1.5),
    ("sheet_radius", -0.01), ("sheet_radius", 0.05), ("sheet_radius", np.nan), ("sheet_line_ratio", 0.0),
    ("sheet_line_ratio", 1.0), ("sheet_min_points", 0), ("sheet_min_points", 4.0), ("motion_view_angle", -0.1),
    ("motion_view_angle", 3.2), ("motion_view_angle", np.nan), ("motion_view_angle", True),
    ("motion_graze_angle", -0.1), ("motion_graze_angle", 1.6), ("motion_graze_angle", "10 deg"),
])
def test_map_config_rejects_bad_values_naming_the_field(name, value):
    with pytest.raises(ValueError, match=name):
        MapConfig(**{name: value})


def test_map_config_needs_the_bucket_on_the_voxel_lattice():
    with pytest.raises(ValueError, match="bucket"):
        MapConfig(voxel=0.01, bucket=0.085)
    MapConfig(voxel=0.01, bucket=0.09)  # a whole multiple is fine


def test_sensed_map_rejects_bad_boxes():
    with pytest.raises(ValueError, match="finite"):
        SensedMap([0, 0, np.nan], [1, 1, 1])
    with pytest.raises(ValueError, match="finite"):
        SensedMap([0, 0], [1, 1])
    with pytest.raises(ValueError, match="empty"):
        SensedMap([0, 0, 0], [-2, 1, 1])
    with pytest.raises(ValueError, match="too large"):
        SensedMap([0, 0, 0], [20, 20, 20])


@pytest.mark.parametrize("bad", ["origins", "directions", "starts", "ranges", "hit", "informative"])
def test_update_rejects_arrays_that_disagree_naming_them(bad):
    """The compiled update reads every array for every ray: one too short must be an error, not a stray read."""
    smap = SensedMap([0, 0, 0], [1, 1, 1])
    rays = {"origins": np.full((4, 3), 0.5), "directions": np.tile([1.0, 0.0, 0.0], (4, 1)),
            "starts": np.zeros(4), "ranges": np.full(4, 0.3), "hit": np.ones(4, bool), "informative": np.ones(4, bool)}
    rays[bad] = rays[bad][:3]
    with pytest.raises(ValueError, match="must agree|must be \\(R, 3\\)"):
        smap.update(**rays)
    assert smap.n_points == 0 and smap.revision == 0


# ---------------------------------------------------------------------------- sensing motion
Y = np.array([0.0, 1.0, 0.0])
DETECT = MapConfig(shadow_depths=())  # the default: not forgetting until motion is sensed


def test_a_clean_pass_contradicts_an_established_point_and_not_a_weak_one():
    """Before motion is sensed, a ray through a point changes no evidence; it counts one contradiction for a
    point at ``max_evidence`` whose latent evidence the passes have used up (once per reading, however many
    rays), and none for a point hit fewer times."""
    smap = _map(DETECT)
    strong, weak = np.array([0.305, 0.205, 0.195]), np.array([0.305, 0.105, 0.195])
    for _ in range(DETECT.max_evidence):  # initial_evidence, then one more per hit, up to max_evidence
        smap.update([strong - 0.2 * X], [X], [0.03], [0.2], [True], [True])
    smap.add_points([weak])
    assert not smap.forgetting and smap.contradicted == 0
    smap.update([weak - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.contradicted == 0
    two = ([strong - 0.2 * X] * 2, [X, X], [0.03] * 2, [0.4] * 2, [False] * 2, [True] * 2)
    for _ in range(DETECT.max_evidence // 2 - 1):  # latent evidence 6 -> 2, two passes a reading
        smap.update(*two)
        assert smap.contradicted == 0
    smap.update(*two)  # latent evidence 0: what forgetting from the start would have removed
    assert smap.contradicted == 1
    for _ in range(20):  # the evidence stays: nothing is forgotten
        smap.update([strong - 0.2 * X, weak - 0.2 * X], [X, X], [0.03] * 2, [0.4] * 2, [False] * 2, [True] * 2)
        assert smap.contradicted == 1
    assert smap.n_points == 2 and not smap.forgetting and smap.motion_sensed_at is None


def test_a_point_hit_again_between_clean_passes_is_no_contradiction():
    """A static surface that rays graze is passed within ``clear_radius`` and hit again, reading after reading
    (a plate's rim seen through its window, a plate seen edge-on): its latent evidence never runs out, so the
    passes are no contradiction (the review worlds' false alarms, map module docstring)."""
    smap = _map(DETECT)
    p = np.array([0.305, 0.205, 0.195])
    hit = ([p - 0.2 * X], [X], [0.03], [0.2], [True], [True])
    for _ in range(DETECT.max_evidence):
        smap.update(*hit)
    for _ in range(30):  # one pass a reading, a hit every other reading: latent evidence 6, 5, 6, 5, ...
        smap.update([p - 0.2 * X], [X], [0.03], [0.4], [False], [True])
        assert smap.contradicted == 0
        smap.update(*hit)
    assert smap.n_points == 1 and not smap.forgetting
    for k in range(DETECT.max_evidence + 1):  # hits stop: the passes use its latent evidence up
        smap.update([p - 0.2 * X], [X], [0.03], [0.4], [False], [True])
        assert smap.contradicted == (k >= DETECT.max_evidence - 1), k


def _unit(deg: float) -> np.ndarray:
    """The unit direction ``deg`` degrees from +x towards +y."""
    return np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg)), 0.0])


@pytest.mark.parametrize("deg", [0.0, 20.0, 28.0, 32.0, 45.0, 90.0, 150.0])
def test_a_pass_contradicts_a_point_only_from_about_where_it_was_sensed(deg):
    """A point sensed by rays along +x is contradicted by a clean pass within ``motion_view_angle`` (30 deg) of
    +x, once its latent evidence is used up, and never by one from further round (a ray grazing a surface seen
    from the front: the review worlds' false alarms, map module docstring); the evidence is kept either way."""
    smap = _map(DETECT)
    p = np.array([0.305, 0.205, 0.195])
    for _ in range(DETECT.max_evidence):  # sensed along +x
        smap.update([p - 0.2 * X], [X], [0.03], [0.2], [True], [True])
    d = _unit(deg)
    counted = []
    for _ in range(DETECT.max_evidence + 3):
        smap.update([p - 0.2 * d], [d], [0.03], [0.4], [False], [True])
        counted.append(smap.contradicted)
    along = deg <= math.degrees(DETECT.motion_view_angle)
    assert counted == [0] * (DETECT.max_evidence - 1) + [int(along)] * 4
    assert smap.n_points == 1 and not smap.forgetting


def test_the_direction_a_point_was_sensed_from_is_the_running_mean_of_its_hits():
    """Sensed along 0 and 20 deg in turn, in either order: its direction is their mean, 10 deg, so a pass along
    25 deg (15 deg off) counts and one along -25 deg (35 deg off) does not (either single direction would
    count it: 25 deg off the first or the last).  A point added without a direction
    (:meth:`SensedMap.add_points`) is contradicted from any direction."""
    cfg = dataclasses.replace(DETECT, average=64, max_evidence=4)
    p = np.array([0.305, 0.205, 0.195])

    def counts(d: np.ndarray, smap: SensedMap) -> int:
        for _ in range(cfg.max_evidence):
            smap.update([p - 0.2 * d], [d], [0.03], [0.4], [False], [True])
        return smap.contradicted

    for order in ((0.0, 20.0), (20.0, 0.0)):
        results = []
        for deg in (25.0, -25.0):
            smap = _map(cfg)
            for _ in range(3):
                for a in order:
                    smap.update([p - 0.2 * _unit(a)], [_unit(a)], [0.03], [0.2], [True], [True])
            results.append(counts(_unit(deg), smap))
        assert results == [1, 0], order
    smap = _map(cfg)
    smap.add_points([p] * cfg.max_evidence)
    assert counts(_unit(120.0), smap) == 1


def test_a_point_added_without_a_direction_takes_its_first_hits():
    """A point added by :meth:`SensedMap.add_points` (no direction) and then hit along +x is sensed from +x, not
    from half of it: a pass along +x counts once its latent evidence is used up, one along +y never."""
    cfg = dataclasses.replace(DETECT, max_evidence=4)
    p = np.array([0.305, 0.205, 0.195])
    counted = {}
    for name, d in (("along", X), ("across", Y)):
        smap = _map(cfg)
        smap.add_points([p])
        for _ in range(cfg.max_evidence):
            smap.update([p - 0.2 * X], [X], [0.03], [0.2], [True], [True])
        counted[name] = []
        for _ in range(cfg.max_evidence + 2):
            smap.update([p - 0.2 * d], [d], [0.03], [0.4], [False], [True])
            counted[name].append(smap.contradicted)
    assert counted == {"along": [0] * (cfg.max_evidence - 1) + [1] * 3, "across": [0] * (cfg.max_evidence + 2)}


def test_a_contradiction_is_judged_by_its_own_ray_among_dropped_and_open_ones():
    """The candidates are judged after the rays, each by the direction of the ray that made it: in readings whose
    first rays are dropped (not informative, or no finite range) and whose others run elsewhere, only the pass
    from the direction the point was sensed from counts."""
    smap = _map(DETECT)
    p = np.array([0.305, 0.205, 0.195])
    for _ in range(DETECT.max_evidence):
        smap.update([p - 0.2 * X], [X], [0.03], [0.2], [True], [True])
    across, along = Y, _unit(10.0)
    counted = []
    for _ in range(DETECT.max_evidence + 1):
        origins = [p - 0.2 * X, p - 0.2 * X, p - 0.2 * across, p + np.array([0.0, 0.0, 0.1]) - 0.2 * X, p - 0.2 * along]
        dirs = [X, X, across, X, along]
        smap.update(origins, dirs, [0.03] * 5, [0.4, np.inf, 0.4, 0.4, 0.4], [False] * 5,
                    [False, True, True, True, True])
        counted.append(smap.contradicted)
    assert counted[: DETECT.max_evidence // 2 - 1] == [0] * (DETECT.max_evidence // 2 - 1)  # two passes a reading
    assert counted[-1] == 1 and not smap.forgetting
    smap = _map(DETECT)  # the same without the pass from the sensing direction: never
    for _ in range(DETECT.max_evidence):
        smap.update([p - 0.2 * X], [X], [0.03], [0.2], [True], [True])
    for _ in range(DETECT.max_evidence + 1):
        smap.update([p - 0.2 * X, p - 0.2 * across], [X, across], [0.03] * 2, [np.inf, 0.4], [False] * 2,
                    [True, True])
        assert smap.contradicted == 0


def test_motion_is_sensed_when_the_contradictions_in_the_window_reach_the_threshold():
    """``motion_contradictions`` within ``motion_window`` readings turn forgetting on from the next reading;
    fewer, spread wider than the window, do not; ``detect_motion=False`` never counts."""
    cfg = MapConfig(shadow_depths=(), motion_contradictions=3, motion_window=2, max_evidence=2)
    p = np.array([0.305, 0.205, 0.195])
    through = ([p - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    beside = ([p - 0.2 * X + [0, 0.1, 0]], [X], [0.03], [0.4], [False], [True])
    smap = _map(cfg)
    smap.add_points([p, p])  # evidence 2 = max_evidence: established
    for _ in range(5):  # one contradiction every other reading: at most 1 in any 2 readings
        smap.update(*through)
        smap.update(*beside)
    assert not smap.forgetting
    smap = _map(cfg)
    smap.add_points([p, p, p + 0.05 * Y, p + 0.05 * Y])
    two = ([p - 0.2 * X, p + 0.05 * Y - 0.2 * X], [X, X], [0.03] * 2, [0.4] * 2, [False] * 2, [True] * 2)
    smap.update(*two)  # latent evidence 2 -> 1: not used up, no contradiction
    assert not smap.forgetting and smap.contradicted == 0
    smap.update(*two)  # used up: 2 contradictions
    assert not smap.forgetting and smap.contradicted == 2
    smap.update(*two)  # 4 in the last 2 readings; the passes took what forgetting would have
    assert smap.forgetting and smap.motion_sensed_at == 3 and smap.n_points == 0
    off = _map(dataclasses.replace(cfg, detect_motion=False))
    off.add_points([p, p])
    for _ in range(5):
        off.update(*through)
    assert off.contradicted == 0 and not off.forgetting and off.n_points == 1


def test_once_motion_is_sensed_the_passes_before_count_as_if_the_map_had_forgotten_all_along():
    """Each point keeps the evidence forgetting would have left it (one less per clean pass, put back by a
    hit): when motion is sensed, that becomes its evidence and the points it would have removed go at once
    (in the tests' door world the trials then end as with forgetting from the start, step for step)."""
    cfg = MapConfig(shadow_depths=(), motion_contradictions=1, motion_window=1, max_evidence=3)
    a, b, c = (np.array([0.305, y, 0.195]) for y in (0.105, 0.205, 0.305))

    def through(*points):
        n = len(points)
        return ([p - 0.2 * X for p in points], [X] * n, [0.03] * n, [0.4] * n, [False] * n, [True] * n)

    smap = _map(cfg)
    smap.add_points([a, a, b, c])  # a: evidence 3 (established), b and c: 2 (initial_evidence)
    smap.update(*through(b))
    smap.update(*through(b, c))  # passes through weak points: no contradiction, nothing forgotten yet
    assert not smap.forgetting and smap.n_points == 3
    smap.add_points([c])  # a hit puts one back: c would be at 2 again
    for _ in range(2):  # a: latent evidence 3 -> 1, not used up: no contradiction
        smap.update(*through(a))
    assert not smap.forgetting and smap.n_points == 3
    smap.update(*through(a))  # used up: a contradiction, motion
    assert smap.forgetting and smap.motion_sensed_at == 5  # the fifth reading
    np.testing.assert_allclose(smap.points, [c], atol=1e-12)  # a and b would have been forgotten; c is at 2
    smap.update(*through(c))  # c: 2 - 1
    assert smap.n_points == 1
    smap.update(*through(c))
    assert smap.n_points == 0


@pytest.mark.parametrize("beside", [DETECT.clear_radius + 0.002, DETECT.sensed_clear_radius - 0.001])
def test_once_motion_is_sensed_a_ray_clears_what_it_passes_within_the_wider_radius(beside):
    """Before motion is sensed a ray counts against a point within ``clear_radius`` of it (4 mm); once sensed,
    within ``sensed_clear_radius`` (1 cm: the rays lie centimetres apart where a moved surface was): a point
    6 or 9 mm beside a ray is kept before and forgotten after; one 2 mm beyond the wider radius is kept (the
    radius's growth along the ray, ``sensed_clear_slope``, off here: the next test)."""
    cfg = dataclasses.replace(DETECT, motion_contradictions=1, motion_window=1, max_evidence=2, sensed_clear_slope=0.0)
    p, q = np.array([0.305, 0.205, 0.195]), np.array([0.305, 0.405, 0.195])
    far = p - 0.02 * Y
    smap = _map(cfg)
    smap.add_points([p, p, far, far])  # both established (evidence 2 = max_evidence)
    near = ([p - 0.2 * X + beside * Y], [X], [0.03], [0.4], [False], [True])
    for _ in range(3):
        smap.update(*near)
    assert smap.n_points == 2 and not smap.forgetting  # beside it (> clear_radius): no pass, no contradiction
    smap.add_points([q, q])
    for _ in range(2):  # through an established point until its latent evidence is used up: motion
        smap.update([q - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.forgetting and smap.n_points == 2  # q gone at once
    for _ in range(2):
        smap.update(*near)
    np.testing.assert_allclose(smap.points, [far], atol=1e-12)  # p forgotten (2 passes); far, 26-29 mm away, kept
    beyond = far - 0.2 * X + (cfg.sensed_clear_radius + 0.002) * np.array([0.0, 0.0, 1.0])
    for _ in range(3):
        smap.update([beyond], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 1


@pytest.mark.parametrize("along", [0.1, 0.25])
def test_once_motion_is_sensed_the_clean_pass_radius_grows_along_the_ray(along):
    """Once sensed, a ray clears the points within ``sensed_clear_radius + sensed_clear_slope a`` of its line,
    ``a`` along it (a cone): at 0.1 and 0.25 m a point 2 mm inside that radius goes, one 2 mm outside stays."""
    cfg = dataclasses.replace(DETECT, motion_contradictions=1, motion_window=1, max_evidence=2)
    radius = cfg.sensed_clear_radius + cfg.sensed_clear_slope * along
    o = np.array([0.105, 0.205, 0.195])
    inside, outside = o + along * X + (radius - 0.002) * Y, o + along * X - (radius + 0.002) * Y
    q = np.array([0.305, 0.405, 0.195])
    smap = _map(cfg)
    smap.add_points([inside, inside, outside, outside, q, q])
    for _ in range(2):  # through an established point until its latent evidence is used up: motion
        smap.update([q - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.forgetting and smap.n_points == 2  # q gone at once
    for _ in range(2):
        smap.update([o], [X], [0.03], [0.4], [False], [True])
    np.testing.assert_allclose(smap.points, [outside], atol=1e-12)


def test_begin_forgetting_drops_what_forgetting_would_have_and_forgets_from_then_on():
    """As motion sensed: a weak point passed cleanly twice (latent evidence 0) goes at once, the version
    changes and ``forgotten`` counts it; a second call changes nothing; later clean passes forget the other."""
    smap = _map(DETECT)
    a, b = np.array([0.305, 0.205, 0.195]), np.array([0.305, 0.405, 0.195])
    smap.add_points([a, b])
    for _ in range(2):
        smap.update([a - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 2 and not smap.forgetting
    version, revision = smap.version, smap.revision
    assert smap.begin_forgetting() == 1
    assert smap.forgetting and smap.n_points == 1 and smap.version > version and smap.revision > revision
    assert smap.motion_sensed_at == smap.readings and smap.forgotten == 1
    assert smap.begin_forgetting() == 0
    for _ in range(2):
        smap.update([b - 0.2 * X], [X], [0.03], [0.4], [False], [True])
    assert smap.n_points == 0 and smap.forgotten == 2


def test_forget_moved_forgets_from_the_start():
    smap = _map(MapConfig(shadow_depths=(), forget_moved=True))
    assert smap.forgetting and smap.motion_sensed_at is None
    smap.end_forgetting()  # not begun by begin_forgetting: no change
    assert smap.forgetting


def test_end_forgetting_ends_what_begin_forgetting_began_and_the_map_senses_motion_afresh():
    """After :meth:`SensedMap.end_forgetting` a clean pass takes nothing (as before begin_forgetting) and
    counts as a contradiction again; motion sensed by the map itself then is forgetting for good."""
    cfg = MapConfig(shadow_depths=(), motion_contradictions=2, motion_window=3)
    a, b, c = np.array([0.305, 0.205, 0.195]), np.array([0.305, 0.105, 0.195]), np.array([0.305, 0.305, 0.195])
    through = {tuple(p): ([p - 0.2 * X], [X], [0.03], [0.4], [False], [True]) for p in (a, b)}
    smap = _map(cfg)
    smap.add_points([a, b, c] * cfg.max_evidence)  # all established
    smap.begin_forgetting()
    smap.update(*through[tuple(a)])
    assert smap.forgetting_for_a_while and smap.n_points == 3  # a lost one evidence of max_evidence
    smap.end_forgetting()
    assert not smap.forgetting and not smap.forgetting_for_a_while and smap.motion_sensed_at is None
    for _ in range(cfg.max_evidence - 1):  # no pass takes anything now; a's latent evidence goes 5 -> 0
        smap.update(*through[tuple(a)])
    assert smap.n_points == 3 and smap.contradicted == 0  # a is no longer established: no contradiction
    for _ in range(cfg.max_evidence - 1):  # b's latent evidence 6 -> 1: not used up
        smap.update(*through[tuple(b)])
        assert smap.contradicted == 0
    smap.update(*through[tuple(b)])
    assert smap.contradicted == 1 and not smap.forgetting
    smap.update(*through[tuple(b)])  # 2 in the window: motion, sensed by the map itself
    assert smap.forgetting and smap.motion_sensed_at == smap.readings and not smap.forgetting_for_a_while
    # what forgetting would have left of each since end_forgetting: a and b nothing (gone at once), c all
    np.testing.assert_allclose(smap.points, [c], atol=1e-12)
    smap.end_forgetting()
    assert smap.forgetting


def _recorded_static_readings():
    """The 200 recorded readings of ``worlds/truss_clutter.json`` (static; seed 0, control steps 150-349) as
    the field planner fuses them: the estimator's ranges, measured rays as hits, rays from 3 cm."""
    from pathlib import Path

    data = np.load(Path(__file__).parent / "data" / "range_readings.npz")
    max_range = float(data["max_range"])
    for k in range(len(data["ranges"])):
        measured = data["out_measured"][k]
        informative = measured | (data["valid"][k] & ~data["out_tracking"][k])
        n = len(measured)
        yield (np.tile(data["origins"][k], (n, 1)), data["directions"][k], np.full(n, 0.03),
               np.where(measured, data["out_ranges"][k], max_range), measured, informative)


def test_a_recorded_static_trial_never_senses_motion():
    readings = list(_recorded_static_readings())
    pts = np.concatenate([o[m] + rg[m, None] * d[m] for o, d, _, rg, m, _ in readings])  # the hits
    smap = SensedMap(pts.min(axis=0) - 0.5, pts.max(axis=0) + 0.5)  # the default config
    window = []
    for r in readings:
        smap.update(*r)
        window = (window + [smap.contradicted])[-smap.config.motion_window:]
    assert not smap.forgetting and smap.motion_sensed_at is None
    assert sum(window) < smap.config.motion_contradictions / 2


def test_a_surface_that_moves_away_is_sensed_and_then_forgotten():
    """A wall seen head-on by a fan of rays for 2 s moves 0.15 m further: the rays now pass through its old
    points.  Motion is sensed within the window, and the old wall is forgotten while the new one stays."""
    g = np.linspace(-0.06, 0.06, 9)
    dirs = np.array([[1.0, a, b] for a in g for b in g])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    o = np.array([0.1, 0.2, 0.2])
    n = len(dirs)
    rng = np.random.default_rng(1)
    smap = _map(MapConfig(shadow_depths=()))
    for k in range(120):
        wall = 0.25 if k < 60 else 0.40  # x of the wall; it moves at reading 60
        ranges = (wall - o[0]) / dirs[:, 0] + rng.normal(0.0, 0.002, n)
        smap.update(np.tile(o, (n, 1)), dirs, np.full(n, 0.03), ranges, np.ones(n, bool), np.ones(n, bool))
        if k == 59:
            assert not smap.forgetting
    assert smap.motion_sensed_at is not None and 61 <= smap.motion_sensed_at <= 61 + smap.config.motion_window
    x = smap.surface_points[:, 0]
    assert len(x) >= 20 and np.all(x > 0.35)  # the old wall forgotten, the new one kept
