"""A sphere "robot" in a bare PyBullet scene, for the contact checks' tests (``tests/test_contact_mutants.py``,
``tests/test_mover_sweep_mutants.py``): worlds of a few obstacles, the probe, PyBullet's own distance, and a
count of the exact distance queries a scene makes."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from navstack.sim.scene import Scene
from navstack.world import Goal, RobotSpec, Sphere, World

R_PROBE = 0.03  # m: the test "robot", a sphere (or a capsule of this radius)


def world_of(*obstacles) -> World:
    """A world of ``obstacles`` and the default robot, its one goal out of the way."""
    return World(name="t", robot=RobotSpec(), obstacles=tuple(obstacles), goals=(Goal([0.0, 0.0, 3.0]),))


def probe_at(c, centre, radius: float = R_PROBE) -> int:
    """A static sphere of ``radius`` [m] at ``centre`` in client ``c``: its body id."""
    shape = c.createCollisionShape(p.GEOM_SPHERE, radius=radius)
    body = c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=[float(x) for x in centre])
    c.performCollisionDetection()
    return body


def probe_boxes(centre, radius: float = R_PROBE):
    """The probe's bounding box as the swept check takes a robot's: (lo (1, 3), hi (1, 3))."""
    c = np.asarray(centre, dtype=np.float64)[None, :]
    return c - radius, c + radius


def pybullet_distance(c, a: int, b: int) -> float:
    """PyBullet's own closest distance between two bodies (spheres: exact)."""
    c.performCollisionDetection()
    return min(pt[8] for pt in c.getClosestPoints(a, b, 1.0))


def counting(scene, monkeypatch) -> list:
    """The arguments of every exact distance query ``scene`` makes from now on (the queries still run)."""
    calls, original = [], scene._exact_distances
    monkeypatch.setattr(scene, "_exact_distances", lambda *a: calls.append(a) or original(*a))
    return calls


def with_a_nearer_static_sphere(client, mover, t: float, gap: float = 0.005):
    """A scene of a static sphere ``gap`` m from the probe (at the origin) on the -x side and ``mover``; the
    probe, and the clearance the look at ``t`` reads (the static sphere's: PyBullet's own distance)."""
    static = Sphere(center=[-(R_PROBE + 0.02 + gap), 0.0, 0.0], radius=0.02)
    scene = Scene.build(client, world_of(static, mover))
    probe = probe_at(client, [0.0, 0.0, 0.0])
    scene.update(t)
    look = scene.clearance(probe)
    assert look == pytest.approx(gap, abs=1e-9)
    assert look == pytest.approx(pybullet_distance(client, probe, scene.obstacle_body[0]), abs=1e-9)
    return scene, probe, look
