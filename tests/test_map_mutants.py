"""The sensed map's clean pass (navstack.planner.map ``_carve``, ``_pass_along``, the ``near`` grid) against its
documented rule, in the cases the mutants of session 46 showed untested: a sensed-motion cone wider than a bucket
(the walk may skip a step only when its radius stays below half a bucket), and readings of several rays, short
ones among them, through the same buckets (each ray its own tag; a ray with no clear part skips only its own pass).

References are independent of the kernels: the rule written out in numpy (a point goes when it lies strictly
between the ray's start and ``end - clear_backoff`` along it and within the clean-pass radius of its line), and
the buckets a segment crosses from fine sampling.
"""

from __future__ import annotations

import numpy as np

from navstack.planner.map import MapConfig, SensedMap

LO, HI = np.zeros(3), np.array([0.6, 0.4, 0.4])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _sorted(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


def _bucket(smap: SensedMap, pts: np.ndarray) -> np.ndarray:
    return np.floor((np.asarray(pts) - smap.origin) / smap.config.bucket).astype(int)


def test_a_sensed_cone_wider_than_a_bucket_clears_points_two_buckets_from_the_ray():
    """Once motion is sensed (here: forgetting begun) the clean-pass radius grows along the ray
    (``sensed_clear_radius + sensed_clear_slope a``), past a bucket (4 cm) 0.25 m out (4.6-5.7 cm here).  A lone
    point 0.85-1.15 of that radius beside a ray (which runs across one axis, the point lying near a bucket face
    across it) goes or stays as the rule says, also when the ray never enters a bucket next to the point's (so no
    bucket of the walk has it among its 27 neighbours: the walk may skip no step of it)."""
    cfg = MapConfig(shadow_depths=(), initial_evidence=1, max_evidence=1, sheet_radius=0.0,
                    motion_contradictions=10_000)
    rng = np.random.default_rng(46)
    wrong, far_named, far_kept = [], 0, 0
    for trial in range(160):
        smap = SensedMap(LO, HI, cfg)
        smap.begin_forgetting()  # sensed radius and slope from the first reading on
        ax = int(rng.integers(3))
        side = np.zeros(3)
        side[ax] = rng.choice([-1.0, 1.0])
        p = rng.uniform(0.15, 0.45, 3) * [1.0, 0.6, 0.6] + [0.0, 0.08, 0.08]
        f = rng.uniform(0.01, 0.15)  # p's place in its bucket along ``ax``, from the face the ray lies beyond
        lo_face = smap.origin[ax] + np.floor((p[ax] - smap.origin[ax]) / cfg.bucket) * cfg.bucket
        p[ax] = lo_face + (f if side[ax] > 0 else 1.0 - f) * cfg.bucket
        smap.add_points([p])
        p = smap.points[0]
        d = rng.normal(size=3)
        d[ax] = 0.0  # the ray runs across ``ax``, ``offset`` from p along it all the way
        d = _unit(d)
        rg = rng.uniform(0.36, 0.44)  # a miss: the clear part ends at rg - clear_backoff (0.31-0.39 m)
        s1 = rg - cfg.clear_backoff
        a = rng.uniform(0.3, s1 - 0.01)
        radius = cfg.sensed_clear_radius + cfg.sensed_clear_slope * a
        offset = rng.uniform(0.85, 1.15) * radius
        if abs(offset - radius) < 1e-6:
            continue
        origin = p - offset * side - a * d  # closest approach to p at ``a`` along the ray, ``offset`` beside it
        named = offset < radius  # the rule (a lies strictly inside the clear part)
        s = np.arange(0.03, s1, 2e-4)
        walk = _bucket(smap, origin + s[:, None] * d)
        far = np.all(np.abs(walk - _bucket(smap, p)).max(axis=1) >= 2)  # no bucket of the walk is next to p's
        far_named += bool(far and named)
        far_kept += bool(far and not named)
        smap.update([origin], [d], [0.03], [rg], [False], [True])
        if smap.n_points != (0 if named else 1):
            wrong.append((trial, p, origin, d, offset, radius, bool(far)))
    assert not wrong, f"{len(wrong)} of 160 wrong, e.g. {wrong[0]}"
    assert far_named >= 25 and far_kept >= 25  # the case exercised, both ways


def test_readings_of_several_rays_short_ones_among_them_clear_what_the_rule_names():
    """Readings of 1-7 rays (misses), each ray through a small ball in a cloud of points, so that the rays of a
    reading and of the readings before cross the same buckets; a quarter of them too short to have a clear part
    (range < start + clear_backoff).  After each reading no point the rule does not name for one of its rays
    is gone, every point it names on one of them (away from the boundaries) is gone, and the cells of every
    ray, short ones and those after them included, are seen free."""
    cfg = MapConfig(shadow_depths=(), forget_moved=True, initial_evidence=1, max_evidence=1)
    rng = np.random.default_rng(146)
    smap = SensedMap(LO, HI, cfg)
    v = cfg.voxel
    keys = {tuple(int(x) for x in rng.integers([8, 8, 8], [52, 32, 32])) for _ in range(2600)}
    cloud = (np.array(sorted(keys)) + 0.5) * v + rng.uniform(-0.003, 0.003, (len(keys), 3))
    smap.add_points(cloud)
    alive = np.ones(len(cloud), dtype=bool)
    checked = short = 0
    target = np.array([0.3, 0.2, 0.2])
    for _ in range(40):
        n = int(rng.integers(1, 8))
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        through = target + rng.uniform(-0.02, 0.02, (n, 3))
        origins = through - rng.uniform(0.1, 0.2, (n, 1)) * d
        ranges = rng.uniform(0.3, 0.4, n)
        cut = rng.random(n) < 0.25
        ranges[cut] = rng.uniform(0.035, 0.03 + cfg.clear_backoff, cut.sum())  # no clear part
        short += int(cut.sum())
        w = cloud[None, :, :] - origins[:, None, :]
        a = np.einsum("rpk,rk->rp", w, d)
        lateral = np.linalg.norm(w - a[:, :, None] * d[:, None, :], axis=2)
        end = ranges[:, None] - cfg.clear_backoff
        named = ((a > 0.03) & (a < end) & (lateral < cfg.clear_radius + 1e-9)).any(axis=0)
        sure = ((a > 0.03 + 1e-6) & (a < end - 1e-6) & (lateral < cfg.clear_radius - 1e-9)).any(axis=0)
        checked += int((sure & alive).sum())
        smap.update(origins, d, np.full(n, 0.03), ranges, np.zeros(n, dtype=bool), np.ones(n, dtype=bool))
        kept = {tuple(p) for p in smap.points}  # stored exactly (distinct voxels, one hit each)
        live = np.array([tuple(p) in kept for p in cloud])
        assert not np.any(live & ~alive), "a point came back"
        assert not np.any(alive & ~named & ~live), "a point the rule does not name was removed"
        assert not np.any(alive & sure & live), "a point the rule names on a clear stretch survived"
        alive &= live
        for r in range(n):  # every ray marks the cells it runs through for half a cell or more free
            s = np.arange(0.03, ranges[r], 1e-4)
            cells, counts = np.unique(np.floor((origins[r] + s[:, None] * d[r] - smap.origin) / cfg.free_cell),
                                      axis=0, return_counts=True)
            crossed = cells[counts * 1e-4 > 0.51 * cfg.free_cell].astype(int)
            assert smap.free[tuple(crossed.T)].all(), f"ray {r} of {n} left a cell it crossed unmarked"
    assert checked >= 40 and short >= 15  # the cases exercised


def test_many_rays_along_a_row_of_established_points_are_judged_each_by_its_view():
    """A reading of 12 rays along a bucket edge, through a row of 168 established points within the clear radius
    of it (2 mm off it in y and z, one a voxel): 2,016 (point, ray) passes, within the reading's room for
    candidate contradictions (4,096), so each is judged by the rule: points sensed from below (+z, 90 degrees
    from the rays, beyond ``motion_view_angle``) are not contradicted; the same points added without a direction
    are, each once.  (A walk that scanned a bucket once per step whose box touches it, three here, would
    overflow that room and count the sensed-from-below points unjudged.)"""
    cfg = MapConfig(shadow_depths=(), initial_evidence=1, max_evidence=1, motion_contradictions=100_000)
    y0, z0 = 0.22, 0.18  # a bucket edge (the buckets' lattice: -0.7 + 0.04 k)
    xs = 0.105 + 0.01 * np.arange(42)
    row = np.array([(x, y0 + sy, z0 + sz) for x in xs for sy in (-0.002, 0.002) for sz in (-0.002, 0.002)])
    n = 12
    along = (np.tile([0.0, y0, z0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)), np.full(n, 0.03), np.full(n, 0.6),
             np.zeros(n, dtype=bool), np.ones(n, dtype=bool))
    for sensed in (True, False):
        smap = SensedMap(LO, HI, cfg)
        if sensed:  # hits from below: each point's direction +z
            k = len(row)
            smap.update(row - [0.0, 0.0, 0.3], np.tile([0.0, 0.0, 1.0], (k, 1)), np.full(k, 0.03), np.full(k, 0.3),
                        np.ones(k, dtype=bool), np.ones(k, dtype=bool))
        else:
            smap.add_points(row)
        np.testing.assert_allclose(_sorted(smap.points), _sorted(row), atol=1e-12)
        smap.update(*along)
        assert smap.contradicted == (0 if sensed else len(row)), sensed
        assert smap.n_points == len(row) and not smap.forgetting
