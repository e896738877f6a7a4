"""Exact capsule-to-primitive distances (navstack.sim.exact_distance) against closed forms, dense sampling and
PyBullet, which is exact on faces and spheres and rounds box corners, edges and cylinder rims by its margin."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest
from pybullet_utils import bullet_client
from scipy.spatial.transform import Rotation

from navstack.sim.exact_distance import (
    MARGIN,
    capsule_distance,
    member_distances,
    primitive_row,
    signed_distance,
)
from navstack.world import Box, Cylinder, Mesh, Sphere

BOX = Box(center=[0.1, 0.2, 0.3], half_extents=[0.2, 0.1, 0.3], rpy=[0.3, -0.5, 1.1])
CYLINDER = Cylinder(p0=[0.0, 0.0, 0.0], p1=[0.3, 0.2, 0.5], radius=0.1)
SPHERE = Sphere(center=[0.0, -0.1, 0.05], radius=0.2)
SHAPES = {"box": BOX, "cylinder": CYLINDER, "sphere": SPHERE}


def test_signed_distance_closed_forms():
    box = Box(center=[1.0, 2.0, 3.0], half_extents=[0.1, 0.2, 0.3])
    e = 0.05
    corner, edge, face = [1.1 + e, 2.2 + e, 3.3 + e], [1.1 + e, 2.2 + e, 3.0], [1.0, 2.0, 3.3 + e]
    np.testing.assert_allclose(signed_distance(box, np.array([corner, edge, face, [1.0, 2.0, 3.0], [1.05, 2.0, 3.0]])),
                               [np.sqrt(3) * e, np.sqrt(2) * e, e, -0.1, -0.05], atol=1e-15)
    cyl = Cylinder(p0=[0.0, 0.0, -1.0], p1=[0.0, 0.0, 1.0], radius=0.5)
    np.testing.assert_allclose(signed_distance(cyl, np.array([[0.5 + e, 0, 1 + e], [0.7, 0, 0], [0.2, 0, 0.1]])),
                               [np.sqrt(2) * e, 0.2, -0.3], atol=1e-15)
    rim = signed_distance(cyl, np.array([0.0, 0.5 + e, 1.0 + e]), shift=np.array([0.0, 0.0, 2.0]))
    assert rim == pytest.approx(e, abs=1e-15)  # moved up by 2 m, the point is beside its side, not its rim
    np.testing.assert_allclose(signed_distance(SPHERE, np.array([[0.0, -0.1, 0.35]])), [0.1], atol=1e-15)
    assert signed_distance(SPHERE, np.array([0.0, -0.1, 0.35])) == pytest.approx(0.1, abs=1e-15)  # one point
    with pytest.raises(TypeError, match="Mesh"):
        signed_distance(Mesh(path="x.obj"), np.zeros(3))


@pytest.mark.parametrize("name", list(SHAPES))
def test_capsule_distance_is_the_minimum_over_the_segment(name):
    """Against 20,001 samples along each of 200 random segments (some crossing the obstacle), moved or not."""
    o, rng = SHAPES[name], np.random.default_rng(1)
    a = rng.normal(size=(200, 3)) * 0.5
    b = a + rng.normal(size=(200, 3)) * 0.3
    r = rng.uniform(0.0, 0.05, 200)
    t = np.linspace(0.0, 1.0, 20001)[:, None]
    for shift in (None, np.array([0.05, -0.2, 0.1])):
        got = capsule_distance(o, a, b, r, shift)
        sampled = np.array([signed_distance(o, a[k] + t * (b[k] - a[k]), shift).min() for k in range(200)]) - r
        assert np.all(got <= sampled + 1e-12)  # never above any sampled point
        np.testing.assert_allclose(got, sampled, atol=2e-5)  # and as low as the samples can tell
        assert np.any(got < 0) and np.any(got > 0)


def test_against_pybullet_exact_on_faces_and_spheres_never_more_than_its_rounding_elsewhere():
    """PyBullet's capsule distances as the independent reference: equal (1e-6 m) to a sphere and to a box or
    cylinder wherever its closest point is on a face; elsewhere PyBullet reads more, by less than MARGIN."""
    c = bullet_client.BulletClient(connection_mode=p.DIRECT)
    try:
        bodies = {}
        for name, o in SHAPES.items():
            if isinstance(o, Box):
                cs = c.createCollisionShape(p.GEOM_BOX, halfExtents=o.half_extents.tolist())
                pose = (o.center.tolist(), Rotation.from_euler("xyz", o.rpy).as_quat().tolist())
            elif isinstance(o, Cylinder):
                cs = c.createCollisionShape(p.GEOM_CYLINDER, radius=o.radius, height=o.length)
                q, _ = Rotation.align_vectors([o.p1 - o.p0], [[0.0, 0.0, 1.0]])
                pose = (((o.p0 + o.p1) / 2).tolist(), q.as_quat().tolist())
            else:
                cs = c.createCollisionShape(p.GEOM_SPHERE, radius=o.radius)
                pose = (o.center.tolist(), [0.0, 0.0, 0.0, 1.0])
            bodies[name] = c.createMultiBody(0.0, cs, -1, *pose)
        rng, R, L = np.random.default_rng(2), 0.025, 0.2
        capsule = c.createMultiBody(0.0, c.createCollisionShape(p.GEOM_CAPSULE, radius=R, height=L), -1, [9, 9, 9])
        exact_faces = {name: 0 for name in SHAPES}
        for _ in range(300):
            centre, rot = rng.normal(size=3) * 0.4, Rotation.random(random_state=rng)
            c.resetBasePositionAndOrientation(capsule, centre.tolist(), rot.as_quat().tolist())
            c.performCollisionDetection()
            half = rot.apply([0.0, 0.0, L / 2])
            for name, o in SHAPES.items():
                points = c.getClosestPoints(capsule, bodies[name], 1.0)
                if not points:
                    continue
                ours = float(capsule_distance(o, [centre - half], [centre + half], [R])[0])
                theirs = min(pt[8] for pt in points)
                if ours <= 0 or theirs <= 0:
                    continue  # penetration depths are defined differently
                assert ours <= theirs + 1e-6, name
                assert theirs - ours < 0.74e-3 < MARGIN, name  # (sqrt 3 - 1) mm at most, at a box corner
                on = np.asarray(points[0][6])  # PyBullet's closest point on the obstacle
                face = isinstance(o, Sphere) or (isinstance(o, Box) and np.sum(np.abs(np.abs(
                    Rotation.from_euler("xyz", o.rpy).inv().apply(on - o.center)) - o.half_extents) < 2e-3) == 1)
                if face:
                    assert ours == pytest.approx(theirs, abs=1e-6), name
                    exact_faces[name] += 1
        assert exact_faces["sphere"] > 50 and exact_faces["box"] > 20
    finally:
        c.disconnect()


def test_the_compiled_distances_equal_the_numpy_reference():
    """``member_distances`` (what the scene runs) against ``capsule_distance`` (numpy), moved obstacles
    included; with a small ``within`` a member is either skipped (then truly farther) or exact."""
    rng = np.random.default_rng(3)
    axes = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [-1.0, 0.2, 0.0])
    members = [Cylinder(p0=[0.1, -0.2, 0.0], p1=(np.array([0.1, -0.2, 0.0]) + 0.4 * np.array(u)).tolist(),
                        radius=0.15) for u in axes]  # a truss's members run along the axes
    shapes = list(SHAPES.values()) * 3 + members
    rows = np.array([primitive_row(o) for o in shapes])
    shifts = rng.normal(size=(len(shapes), 3)) * 0.05
    boxes = []
    for o, s in zip(shapes, shifts, strict=True):
        x = np.stack(np.meshgrid(*[np.linspace(-1.0, 1.0, 51)] * 3), axis=-1).reshape(-1, 3)  # 4 cm apart
        inside = x[signed_distance(o, x, s) <= 0.0]
        boxes.append((inside.min(axis=0) - 0.04, inside.max(axis=0) + 0.04))  # holds it
    lo, hi = (np.array(v) for v in zip(*boxes, strict=True))
    a = np.vstack([rng.normal(size=(4, 3)), rng.normal(size=(4, 3)) * 0.2])  # far, and crossing the shapes
    b = a + rng.normal(size=(8, 3)) * 0.2
    r = rng.uniform(0.01, 0.05, 8)
    index = np.arange(len(shapes), dtype=np.int64)
    reference = np.array([capsule_distance(o, a, b, r, s).min() for o, s in zip(shapes, shifts, strict=True)])
    out = np.empty(len(shapes))
    member_distances(rows, index, shifts, lo, hi, a, b, r, 10.0, out)
    np.testing.assert_allclose(out, reference, atol=1e-12)
    assert np.sum(reference < 0) >= 5  # insides compared too
    far = 4  # with only the far capsules, some members are skipped
    reference = np.array([capsule_distance(o, a[:far], b[:far], r[:far], s).min()
                          for o, s in zip(shapes, shifts, strict=True)])
    within = float(np.min(reference)) + 0.05
    member_distances(rows, index, shifts, lo, hi, a[:far], b[:far], r[:far], within, out)
    skipped = np.isinf(out)
    assert skipped.any() and not skipped.all()
    np.testing.assert_allclose(out[~skipped], reference[~skipped], atol=1e-12)  # those asked: exact ...
    assert np.all(reference[skipped] > within)  # ... and those skipped farther than `within`
    one, first = np.empty(1), np.zeros(1, dtype=np.int64)  # capsule by capsule, too
    for k in range(len(a)):
        member_distances(rows, first, shifts, lo, hi, a[k:k + 1], b[k:k + 1], r[k:k + 1], 10.0, one)
        assert one[0] == pytest.approx(capsule_distance(shapes[0], a[k:k + 1], b[k:k + 1], r[k:k + 1],
                                                        shifts[0])[0], abs=1e-12)
