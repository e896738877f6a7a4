"""The planner's potential (navstack.planner.potential): the repulsion's cost rate and the navigation function.

References: the documented cost profile written out in closed form; the 26-connected grid metric in
closed form (in free space Dijkstra on the grid gives exactly min over the goal cells of
``cell * (c sqrt3 + (b - c) sqrt2 + (a - b))`` for index offsets a >= b >= c); an independent Dijkstra
(scipy.sparse.csgraph) over a cost grid rebuilt from the documented rules with a k-d tree; and hand
computations of path lengths through openings.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _clouds import box_surface
from scipy.ndimage import gaussian_filter
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from navstack.planner import potential
from navstack.planner.map import MapConfig, SensedMap
from navstack.planner.potential import BLOCKED, Repulsion, cost_rate, navigation_function
from navstack.planner.proximity import point_index

REP = Repulsion()
RB = REP.r_block
SQ3_MAX = 1.1280928  # largest ratio of the 26-connected grid metric to the Euclidean one (3D, measured)


def _rate(smap: SensedMap, p, rep: Repulsion = REP, r_block: float | None = None) -> float:
    free, _, fcell, fdims = smap.free_arrays()
    rb = rep.r_block if r_block is None else r_block
    return float(cost_rate(p[0], p[1], p[2], rb, rep.vector(), *point_index(smap), free, fcell, fdims))


def _expected_rate(d: float, seen: bool, rep: Repulsion = REP) -> float:
    """The documented profile, in closed form."""
    if d < rep.r_block:
        return BLOCKED
    c = rep.w_repulse * ((rep.influence - d) / (rep.influence - rep.r_block)) ** 2 if d < rep.influence else 0.0
    if not seen:
        c += rep.w_unseen_surface if d < rep.unseen_radius else rep.w_unseen
    return c


def _all_seen(smap: SensedMap) -> None:
    smap.mark_free(smap.origin + 0.5 * smap.free_dims * smap.config.free_cell, 10.0)
    assert smap.free.all()


def _cell_centres(nav) -> np.ndarray:
    idx = np.indices(nav.values.shape).reshape(3, -1).T
    return nav.origin + (idx + 0.5) * nav.cell


def _octile(delta_idx: np.ndarray) -> np.ndarray:
    a = np.sort(np.abs(delta_idx), axis=-1)
    c, b, a = a[..., 0], a[..., 1], a[..., 2]
    return c * math.sqrt(3.0) + (b - c) * math.sqrt(2.0) + (a - b)


def _seeds(nav, goal, reach) -> np.ndarray:
    centres = _cell_centres(nav)
    near = np.linalg.norm(centres - goal, axis=1) <= reach + 0.5 * nav.cell
    return np.indices(nav.values.shape).reshape(3, -1).T[near]


# ---------------------------------------------------------------------------- cost rate
@pytest.mark.parametrize("seen", [True, False])
def test_cost_rate_profile_against_the_closed_form(seen):
    smap = SensedMap([0, 0, 0], [0.5, 0.3, 0.3])
    p0 = np.array([0.205, 0.105, 0.115])
    smap.add_points([p0])
    if seen:
        _all_seen(smap)
    direction = np.array([0.6, -0.48, 0.64])  # unit
    for d in np.concatenate([np.linspace(0.0, 0.12, 241), [RB - 1e-6, RB, REP.unseen_radius - 1e-6,
                                                          REP.unseen_radius, REP.influence - 1e-6]]):
        got = _rate(smap, p0 + d * direction)
        assert got == pytest.approx(_expected_rate(d, seen), abs=1e-9), f"d = {d}"


def test_cost_rate_reads_the_seen_free_cell_of_each_point_in_every_layer_and_beyond_the_box():
    """The unseen cost against the map's own lookup (:meth:`SensedMap.is_seen_free`), far from any surface: a box
    whose corner differs in x, y and z, free balls over its faces (the first and last layers of every axis), and
    points inside, on and beyond the box (beyond it nothing is seen, whatever the far side's cells hold)."""
    smap = SensedMap([-0.37, 0.11, 0.52], [0.1, 0.5, 0.9], MapConfig(margin=0.05))
    assert len(set(smap.origin.tolist())) == 3
    lo = smap.origin
    hi = smap.origin + smap.free_dims * smap.config.free_cell
    rng = np.random.default_rng(5)
    for t in range(18):
        c = rng.uniform(lo, hi)
        axis = t % 3
        c[axis] = lo[axis] if t % 2 else hi[axis]  # a ball on a face: the first or the last layer along ``axis``
        smap.mark_free(c, 0.1)
    probes = rng.uniform(lo - 0.05, hi + 0.05, size=(3000, 3))
    seen = np.array([smap.is_seen_free(p) for p in probes])
    assert 300 < seen.sum() < 2700
    rates = np.array([_rate(smap, p) for p in probes])
    np.testing.assert_array_equal(rates == 0.0, seen)
    np.testing.assert_array_equal(rates[~seen], REP.w_unseen)


def test_cost_rate_landmarks():
    """The profile's shape: forbidden below r_block, w_repulse at r_block, zero by influence when seen,
    w_unseen_surface near a surface and w_unseen far from any when not seen."""
    smap = SensedMap([0, 0, 0], [0.5, 0.3, 0.3])
    p0 = np.array([0.2, 0.1, 0.1])
    smap.add_points([p0])
    x = np.array([1.0, 0.0, 0.0])
    assert _rate(smap, p0 + (RB - 1e-4) * x) == BLOCKED
    assert _rate(smap, p0 + RB * x) == pytest.approx(REP.w_repulse + REP.w_unseen_surface)
    assert _rate(smap, p0 + 0.2 * x) == pytest.approx(REP.w_unseen)  # unseen, far from any surface
    _all_seen(smap)
    assert _rate(smap, p0 + RB * x) == pytest.approx(REP.w_repulse)
    assert _rate(smap, p0 + REP.influence * x) == 0.0
    assert _rate(smap, p0 + 0.2 * x) == 0.0  # seen free, far from surfaces
    # the monotone fall between r_block and influence
    rates = [_rate(smap, p0 + d * x) for d in np.linspace(RB, REP.influence, 50)]
    assert np.all(np.diff(rates) < 0) and rates[-1] == 0.0
    # the caller may relax r_block (the search does, near its start)
    assert _rate(smap, p0 + 0.03 * x) == BLOCKED
    assert _rate(smap, p0 + 0.03 * x, r_block=0.028) == pytest.approx(REP.w_repulse)  # clipped at 1


def test_cost_rate_uses_the_nearest_of_many_points():
    rng = np.random.default_rng(0)
    smap = SensedMap([0, 0, 0], [0.5, 0.5, 0.5])
    pts = rng.uniform(0.0, 0.5, (300, 3))
    smap.add_points(pts)
    pts = smap.points
    tree = cKDTree(pts)
    smap.free[: smap.free_dims[0] // 2 + 8] = 1  # the cells below x ~ 0.03 seen free, the rest not
    q = rng.uniform(-0.05, 0.55, (800, 3))
    for p in q:
        d = float(tree.query(p)[0])
        seen = smap.is_seen_free(p)
        assert _rate(smap, p) == pytest.approx(_expected_rate(d, seen), abs=1e-9)


def test_cost_rate_with_an_influence_beyond_the_map_bucket():
    rep = Repulsion(influence=0.15)
    smap = SensedMap([0, 0, 0], [0.5, 0.3, 0.3])
    p0 = smap.origin + np.array([12 * 0.08 + 0.07, 10 * 0.08 + 0.04, 10 * 0.08 + 0.04])  # 7 cm into a bucket
    smap.add_points([p0])
    _all_seen(smap)
    got = _rate(smap, p0 + np.array([0.12, 0.0, 0.0]), rep)  # two buckets on
    assert got == pytest.approx(_expected_rate(0.12, True, rep))


@pytest.mark.parametrize(("name", "value"), [("body_radius", -0.01), ("margin", np.nan), ("influence", np.inf),
                                             ("w_repulse", True), ("w_unseen", "0.05")])
def test_repulsion_rejects_bad_values(name, value):
    with pytest.raises(ValueError, match=name):
        Repulsion(**{name: value})


def test_repulsion_needs_the_influence_beyond_the_blocking_radius():
    assert Repulsion().r_block == pytest.approx(0.035)
    with pytest.raises(ValueError, match="influence"):
        Repulsion(body_radius=0.03, margin=0.01, influence=0.04)


# ---------------------------------------------------------------------------- navigation function: free space
GOAL = np.array([0.6, 0.05, -0.03])
REACH = 0.014
BOX_LO, BOX_HI = np.array([-0.2, -0.3, -0.25]), np.array([0.8, 0.35, 0.25])


@pytest.mark.parametrize("seen", [True, False])
def test_navigation_function_in_free_space_is_the_grid_metric_to_the_goal_ball(seen):
    smap = SensedMap([0, 0, 0], GOAL)
    if seen:
        _all_seen(smap)
    nav = navigation_function(smap, GOAL, REACH, BOX_LO, BOX_HI, REP)
    # the grid covers the box, on the map's seen-free lattice
    assert np.all(nav.origin <= BOX_LO + 1e-12) and np.all(nav.origin + np.array(nav.values.shape) * nav.cell
                                                          >= BOX_HI - 1e-12)
    assert nav.cell == smap.config.free_cell
    np.testing.assert_allclose((nav.origin - smap.origin) / nav.cell,
                               np.round((nav.origin - smap.origin) / nav.cell), atol=1e-9)
    # exact: the 26-connected metric from the goal cells, times 1 + w_unseen where nothing was seen
    idx = np.indices(nav.values.shape).reshape(3, -1).T
    seeds = _seeds(nav, GOAL, REACH)
    assert len(seeds) >= 1
    ref = np.min([_octile(idx - s) for s in seeds], axis=0) * nav.cell * (1.0 if seen else 1.0 + REP.w_unseen)
    np.testing.assert_allclose(nav.values.reshape(-1), ref, rtol=1e-12, atol=1e-12)
    if not seen:
        return
    # against the straight distance to the goal ball: the grid's error, quantified
    true = np.maximum(np.linalg.norm(_cell_centres(nav) - GOAL, axis=1) - REACH, 0.0)
    v = nav.values.reshape(-1)
    assert np.all(v >= true - 0.5 * nav.cell - 1e-12)
    # (a goal cell lies within true + 1.25 cells: the cell of the point r - 0.37 cell from the goal on the way)
    assert np.all(v <= SQ3_MAX * (true + 1.25 * nav.cell) + 1e-12)
    far = true > 0.3
    rel = (v[far] - true[far]) / true[far]
    print(f"\nnavigation function vs straight distance (> 0.3 m): relative error {rel.min():+.3f} .. "
          f"{rel.max():+.3f} (bound {SQ3_MAX - 1:.3f}), absolute {np.abs(v - true).max() * 1e3:.1f} mm max")
    assert rel.max() <= SQ3_MAX - 1 + 0.02
    # along the grid axes the metric is exact up to the goal cells' half cell
    start = np.array([0.0, 0.05, -0.03])
    assert nav.lookup(start) == pytest.approx(np.linalg.norm(GOAL - start) - REACH, abs=nav.cell)


def test_navigation_function_lookup_outside_its_box_is_inf():
    smap = SensedMap([0, 0, 0], GOAL)
    nav = navigation_function(smap, GOAL, REACH, BOX_LO, BOX_HI, REP)
    assert nav.lookup(BOX_LO - 0.1) == math.inf
    assert nav.lookup(BOX_HI + 0.1) == math.inf
    assert math.isfinite(nav.lookup(0.5 * (BOX_LO + BOX_HI)))


# ---------------------------------------------------------------------------- walls
WALL_X = 0.3


def _wall(hole=None, slot=None, spacing=0.01):
    """Points of the plane x = WALL_X over |y| <= 0.7, |z| <= 0.5 (beyond the navigation box), every ``spacing``.

    ``hole``: (y0, z0, h): no points with |y - y0| < h and |z - z0| < h.  ``slot``: (y0, w): no points with
    |y - y0| < w / 2 (the slot's edges keep their points).
    """
    y, z = np.meshgrid(np.arange(-0.7, 0.7 + 1e-9, spacing), np.arange(-0.5, 0.5 + 1e-9, spacing), indexing="ij")
    y, z = y.ravel(), z.ravel()
    keep = np.ones(len(y), dtype=bool)
    if hole is not None:
        y0, z0, h = hole
        keep &= ~((np.abs(y - y0) < h - 1e-9) & (np.abs(z - z0) < h - 1e-9))
    if slot is not None:
        y0, w = slot
        keep &= np.abs(y - y0) >= 0.5 * w - 1e-9
    pts = np.column_stack([np.full(len(y), WALL_X), y, z])[keep]
    if slot is not None:  # points exactly on the slot's edges
        y0, w = slot
        zz = np.arange(-0.5, 0.5 + 1e-9, spacing)
        edges = [np.column_stack([np.full(len(zz), WALL_X), np.full(len(zz), y0 + s * 0.5 * w), zz]) for s in (-1, 1)]
        pts = np.vstack([pts, *edges])
    return pts


def _wall_map(points) -> SensedMap:
    smap = SensedMap([0, 0, 0], [0.6, 0, 0], MapConfig())
    smap.add_points(points)
    return smap


def _reference_nav(smap: SensedMap, nav, goal, reach, rep: Repulsion = REP) -> np.ndarray:
    """A second implementation: the documented cost grid (k-d tree distances) and scipy's Dijkstra."""
    shape = nav.values.shape
    centres = _cell_centres(nav)
    pts = smap.points
    d = cKDTree(pts).query(centres)[0] if len(pts) else np.full(len(centres), np.inf)
    i0 = np.round((nav.origin - smap.origin) / nav.cell).astype(int)
    seen = smap.free[i0[0]: i0[0] + shape[0], i0[1]: i0[1] + shape[1], i0[2]: i0[2] + shape[2]].reshape(-1) != 0
    cost = np.where(seen, 0.0, np.where(d <= rep.unseen_radius, max(rep.w_unseen_surface, rep.w_unseen),
                                        rep.w_unseen))
    blocked = d <= max(rep.r_block - 0.5 * math.sqrt(3.0) * nav.cell, 0.0)
    seeds = np.flatnonzero((np.linalg.norm(centres - goal, axis=1) <= reach + 0.5 * nav.cell) & ~blocked)
    return _grid_dijkstra(np.where(blocked, -1.0, cost).reshape(shape), seeds, nav.cell)


NAV_LO, NAV_HI = np.array([-0.1, -0.3, -0.2]), np.array([0.7, 0.45, 0.2])
GOAL_BEHIND = np.array([0.6, 0.0, 0.0])


def test_behind_a_wall_with_one_hole_the_value_is_the_length_through_the_hole():
    y0, h = 0.25, 0.065  # hole |y - 0.25| < 0.065, |z| < 0.065: nearest points at 0.07 from its centre
    smap = _wall_map(_wall(hole=(y0, 0.0, h)))
    _all_seen(smap)
    nav = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP)
    ref = _reference_nav(smap, nav, GOAL_BEHIND, REACH)
    np.testing.assert_allclose(nav.values, ref, rtol=1e-9, atol=1e-12)  # inf where unreachable, too
    start = np.array([0.0, 0.0, 0.0])
    v = nav.lookup(start)
    # by hand: through the hole's near edge (y = 0.18 at the points, y = 0.215 with r_block of clearance)
    def through(edge_y):
        return (np.linalg.norm(np.array([WALL_X, edge_y, 0.0]) - start)
                + np.linalg.norm(GOAL_BEHIND - np.array([WALL_X, edge_y, 0.0])) - REACH)
    shortest, clear = through(y0 - h - 0.005), through(y0 - h - 0.005 + RB)
    print(f"\nwall with a hole: navigation function {v:.4f} m; by hand {shortest:.4f} m (touching the edge) .. "
          f"{clear:.4f} m (r_block clear); straight {np.linalg.norm(GOAL_BEHIND - start) - REACH:.4f} m")
    # never shorter than the geometric shortest path through the hole (less the start cell's centre offset
    # and the goal cells' half cell: 1.4 cells)
    assert v >= shortest - 1.5 * nav.cell
    assert v <= SQ3_MAX * (clear + math.sqrt(3.0) * nav.cell)  # a clear path exists, up to the grid's error
    assert v > np.linalg.norm(GOAL_BEHIND - start) + 0.08  # it does go round by the hole
    # the hole's middle is reachable, the wall itself is not
    assert math.isfinite(nav.lookup([WALL_X, y0, 0.0]))
    assert nav.lookup([WALL_X, -0.1, 0.0]) == math.inf


def test_a_wall_without_a_hole_leaves_the_near_side_unreachable():
    smap = _wall_map(_wall())
    _all_seen(smap)
    nav = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP)
    centres = _cell_centres(nav).reshape(*nav.values.shape, 3)
    near_side = centres[..., 0] < WALL_X - 0.04
    far_side = centres[..., 0] > WALL_X + 0.04
    assert np.all(np.isinf(nav.values[near_side]))
    assert np.all(np.isfinite(nav.values[far_side]))
    assert nav.lookup([0.0, 0.0, 0.0]) == math.inf


def test_an_enclosed_goal_is_unreachable_from_outside():
    c, a = np.array([0.5, 0.0, 0.0]), 0.12
    smap = SensedMap([0, 0, 0], c)
    smap.add_points(box_surface(c, a))
    nav = navigation_function(smap, c, REACH, NAV_LO, NAV_HI, REP)
    assert math.isfinite(nav.lookup(c + [0.03, 0.0, 0.0]))
    assert nav.lookup([0.0, 0.0, 0.0]) == math.inf
    assert nav.lookup(c + [0.2, 0.0, 0.0]) == math.inf


@pytest.mark.parametrize("y0", [0.0, 0.004, 0.01, 0.013, 0.019])
def test_a_slot_with_r_block_clearance_on_its_centre_line_stays_open(y0):
    """Slot 2 r_block + 1 cm wide (edges of points at y0 +- 0.04): its far side is finite, whatever the
    slot's offset against the grid, and costs about the straight distance (the slot is on the way)."""
    width = 2 * RB + 0.01
    smap = _wall_map(_wall(slot=(y0, width)))
    _all_seen(smap)
    goal = np.array([0.6, y0, 0.0])
    nav = navigation_function(smap, goal, REACH, NAV_LO, NAV_HI, REP)
    start = np.array([0.0, y0, 0.0])
    v = nav.lookup(start)
    assert math.isfinite(v)
    straight = np.linalg.norm(goal - start) - REACH
    assert straight - 1.5 * nav.cell <= v <= straight + 2 * nav.cell
    ref = _reference_nav(smap, nav, goal, REACH)
    np.testing.assert_allclose(nav.values, ref, rtol=1e-9, atol=1e-12)


def test_a_cell_is_blocked_only_if_it_lies_wholly_within_r_block_of_a_surface():
    """In an open map (sparse random points, all reachable but for blocked cells), the cells left at inf
    are exactly those whose centres lie within r_block - half a cell diagonal of a point: never a cell
    with a point the tip centre may occupy."""
    rng = np.random.default_rng(1)
    smap = SensedMap([0, 0, 0], [0.6, 0, 0])
    smap.add_points(rng.uniform(NAV_LO + 0.05, NAV_HI - 0.05, (150, 3)))
    _all_seen(smap)
    nav = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP)
    d = cKDTree(smap.points).query(_cell_centres(nav))[0]
    inf = np.isinf(nav.values.reshape(-1))
    half_diag = 0.5 * math.sqrt(3.0) * nav.cell
    assert np.all(d[inf] <= RB - half_diag + 1e-12)
    assert np.all(np.isfinite(nav.values.reshape(-1)[d > RB - half_diag + 1e-9]))
    assert inf.sum() > 0


def test_unseen_space_near_surfaces_costs_more_in_the_navigation_function():
    """Unseen cells next to sensed points cost w_unseen_surface per metre: with the wall's hole unseen, the
    way through it costs more than with the hole seen, and matches the reference grid either way."""
    smap = _wall_map(_wall(hole=(0.25, 0.0, 0.065)))
    nav_unseen = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP)
    np.testing.assert_allclose(nav_unseen.values, _reference_nav(smap, nav_unseen, GOAL_BEHIND, REACH),
                               rtol=1e-9, atol=1e-12)
    _all_seen(smap)
    nav_seen = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP)
    start = np.zeros(3)
    assert nav_unseen.lookup(start) > nav_seen.lookup(start) + 0.1


# ---------------------------------------------------------------------------- the wavefront runs on demand
def _settled(nav) -> int:
    return int((nav.wave[4] == -2).sum())


def _grid_dijkstra(cost: np.ndarray, seeds: np.ndarray, cell: float) -> np.ndarray:
    """scipy's Dijkstra over the 26-connected grid of ``cost`` (< 0 blocked), each step costing its length times
    (1 + the mean of its cells' costs), from the flat cells ``seeds``: the wavefront's definition, a second
    implementation."""
    shape = cost.shape
    idx = np.indices(shape).reshape(3, -1).T
    flat = np.arange(cost.size).reshape(shape)
    c = cost.reshape(-1)
    rows, cols, w = [], [], []
    for step in np.ndindex(3, 3, 3):
        step = np.array(step) - 1
        if not step.any():
            continue
        j = idx + step
        ok = np.all((j >= 0) & (j < shape), axis=1)
        a, b = flat[tuple(idx[ok].T)], flat[tuple(j[ok].T)]
        good = (c[a] >= 0) & (c[b] >= 0)
        a, b = a[good], b[good]
        rows.append(a)
        cols.append(b)
        w.append(cell * math.sqrt(float(step @ step)) * (1.0 + 0.5 * (c[a] + c[b])))
    graph = coo_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(cost.size, cost.size)).tocsr()
    return dijkstra(graph, indices=seeds, min_only=True).reshape(shape)


def _blob_costs(seed: int, shape: tuple[int, int, int], dearest: float) -> np.ndarray:
    """A cost grid of blobs, as a map's: smoothed noise cut into free (0), unseen (0.05), unseen near a
    surface (``dearest``) and blocked (-1) regions."""
    base = gaussian_filter(np.random.default_rng(seed).random(shape), 1.5)
    q = np.quantile(base, [0.4, 0.7, 0.88])
    return np.select([base > q[2], base > q[1], base > q[0]], [-1.0, dearest, 0.05], 0.0)


@pytest.mark.parametrize("dearest", [0.05, 6.0, 250.0])
def test_the_wavefront_equals_dijkstra_bit_for_bit_on_random_cost_grids(dearest):
    """The bucket queue settles a bucket's cells in any order; the values must still be Dijkstra's, bit for bit:
    ten grids of cost blobs along a tube (few ways round, so a wrong order shows), each seeded at one end
    cell, asked one cell at a time in a random order, then finished.  ``dearest`` 250: a step costs up to 436
    bucket widths, so the ring of buckets wraps round many times on the way."""
    cell, origin, shape = 0.02, np.zeros(3), (40, 6, 6)
    for seed in range(10):
        cost = _blob_costs(seed, shape, dearest)
        goal_cell = np.array([0, 3, 3])
        cost[tuple(goal_cell)] = 0.0
        wave = potential._wave_state(cost, cell)
        potential._wave_seed(wave, origin + (goal_cell + 0.5) * cell, 0.0, origin, cell)  # the goal's cell only
        ref = _grid_dijkstra(cost, np.ravel_multi_index(tuple(goal_cell), shape), cell)
        assert np.isfinite(ref).sum() > 0.3 * cost.size, seed
        nav = potential.NavigationFunction(origin, cell, np.empty(shape), wave)
        rng = np.random.default_rng(seed)
        for c in rng.permutation(np.argwhere(cost >= 0))[:40]:
            assert nav.lookup(origin + (c + 0.5) * cell) == ref[tuple(c)], (seed, c)
        np.testing.assert_array_equal(nav.values, ref)


@pytest.mark.parametrize("seen", [True, False])
def test_values_asked_one_by_one_are_the_finished_wavefronts_bit_for_bit(seen):
    """The wavefront settles cells only as far as each question needs: every value it gives, asked in a
    random order (blocked cells and cells behind the wall too), equals the finished grid's bit for bit; a
    question near the goal settles a small part of the grid; finishing it gives the finished grid."""
    smap = _wall_map(_wall(hole=(0.25, 0.0, 0.065)))
    if seen:
        _all_seen(smap)
    done = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP).values
    nav = navigation_function(smap, GOAL_BEHIND, REACH, NAV_LO, NAV_HI, REP)
    assert _settled(nav) == 0
    assert nav.lookup(GOAL_BEHIND + [0.05, 0.0, 0.0]) == done[tuple(np.floor((GOAL_BEHIND + [0.05, 0, 0] - nav.origin)
                                                                           / nav.cell).astype(int))]
    assert 0 < _settled(nav) < 0.02 * done.size
    rng = np.random.default_rng(11)
    cells = rng.integers(0, done.shape, size=(400, 3))
    order = np.argsort(np.linalg.norm(nav.origin + (cells + 0.5) * nav.cell - GOAL_BEHIND, axis=1))
    cells = np.vstack([cells[order[:200]], rng.permutation(cells[order[200:]])])  # near ones first, then any
    counts = []
    for c in cells:
        p = nav.origin + (c + rng.uniform(0.05, 0.95, 3)) * nav.cell
        v = nav.lookup(p)
        assert v == done[tuple(c)], (c, v, done[tuple(c)])
        counts.append(_settled(nav))
    assert np.all(np.diff(counts) >= 0)
    assert np.isinf(done[tuple(cells.T)]).any() and np.isfinite(done[tuple(cells.T)]).sum() > 300
    np.testing.assert_array_equal(nav.values, done)
    assert _settled(nav) == np.isfinite(done).sum()


@pytest.mark.parametrize("radius", [0.0, 0.007, 0.018, 0.02, 0.065, 0.1])
def test_rasterize_marks_exactly_the_cells_whose_centre_is_within_reach(radius):
    """Against a brute force over every cell and point, with the kernel's own arithmetic (so the same cells,
    ties included): points inside, near and beyond the grid's faces, some of them dead."""
    from navstack.planner.potential import _rasterize

    rng = np.random.default_rng(int(radius * 1e4))
    cell, dims, origin = 0.02, np.array([13, 9, 11]), np.array([-0.1, 0.2, -0.05])
    size = dims * cell
    P = origin + rng.uniform(-0.15, 1.15, size=(150, 3)) * size
    P[:40] = origin + np.round(rng.uniform(0, 1, size=(40, 3)) * dims) * cell  # on cell faces
    alive = rng.uniform(size=len(P)) < 0.9
    out = np.zeros(tuple(dims))
    _rasterize(P, alive, len(P), origin, cell, dims, radius, out, 7.0)
    idx = np.indices(dims).reshape(3, -1).T
    c = [origin[a] + (idx[:, a] + 0.5) * cell for a in range(3)]
    ref = np.zeros(len(idx), dtype=bool)
    for q in np.flatnonzero(alive):
        x, y, z = c[0] - P[q, 0], c[1] - P[q, 1], c[2] - P[q, 2]
        ref |= x * x + y * y + z * z <= radius * radius
    np.testing.assert_array_equal(out.reshape(-1) == 7.0, ref)
    assert set(np.unique(out)) <= {0.0, 7.0}
    if radius >= 0.018:
        assert 0 < ref.sum() and (radius > 0.05 or ref.sum() < ref.size)
