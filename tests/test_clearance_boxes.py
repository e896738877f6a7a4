"""Scene.clearance with the robot's link boxes (issue 11): the same number as without them, cheaper."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from navstack.jpl import jpl_serpentine
from navstack.sim._bullet import direct_client
from navstack.sim.body import RobotBody
from navstack.sim.scene import Scene
from navstack.world import load_world, world_from_dict

ROOT = Path(__file__).resolve().parents[1]


def _world(tmp_path: Path, rng: np.random.Generator, around: np.ndarray) -> dict:
    """Random primitives (two moving) and meshes within 0.8 m (per axis) of points of the robot, and far ones."""
    cube = trimesh.creation.box(extents=[0.1, 0.1, 0.1])
    cube.export(tmp_path / "cube.stl")
    data = load_world(ROOT / "worlds" / "paper_truss.json").to_dict()
    obstacles = []
    for i in range(24):
        c = around[rng.integers(len(around))] + rng.uniform(-0.8, 0.8, 3)
        kind = i % 4
        if kind == 0:
            d = rng.normal(size=3)
            d *= rng.uniform(0.1, 0.6) / np.linalg.norm(d)
            obstacles.append({"type": "cylinder", "p0": (c - d).tolist(), "p1": (c + d).tolist(),
                              "radius": float(rng.uniform(0.01, 0.05))})
        elif kind == 1:
            obstacles.append({"type": "box", "center": c.tolist(), "half_extents": rng.uniform(0.01, 0.1, 3).tolist(),
                              "rpy": rng.uniform(-np.pi, np.pi, 3).tolist()})
        elif kind == 2:
            obstacles.append({"type": "sphere", "center": c.tolist(), "radius": float(rng.uniform(0.01, 0.1))})
        else:
            obstacles.append({"type": "mesh", "path": "cube.stl", "position": c.tolist(),
                              "rpy": rng.uniform(-np.pi, np.pi, 3).tolist()})
    for _ in range(20):  # far ones: beyond any threshold
        c = np.array([rng.uniform(-3, 3), rng.uniform(6, 9), rng.uniform(0, 2)])
        obstacles.append({"type": "sphere", "center": c.tolist(), "radius": 0.05})
    obstacles[0]["motion"] = {"type": "linear", "velocity": [0.05, -0.02, 0.01], "start": 0.0, "stop": 10.0}
    obstacles[2]["motion"] = {"type": "linear", "velocity": [-0.03, 0.04, 0.0], "start": 1.0, "stop": 8.0}
    data["obstacles"] = obstacles
    return data


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_link_boxes_give_the_same_clearance(tmp_path, seed):
    rng = np.random.default_rng(seed)
    chain = jpl_serpentine()
    base = load_world(ROOT / "worlds" / "paper_truss.json").robot
    T0 = base.base.transform()
    q0 = chain.check(base.q0)
    around = (T0 @ chain.frames(q0))[1:22, :3, 3]  # the origins of frames 1..21 in the world
    world = world_from_dict(_world(tmp_path, rng, around), source=tmp_path / "w.json")
    client = direct_client()
    try:
        body = RobotBody.build(client, chain, T0, serpentine_radius=base.serpentine_radius,
                               arm_radius=base.arm_radius)
        scene = Scene.build(client, world)
        seen = {"negative": 0, "staged": 0, "horizon": 0}
        for k in range(60):
            q = q0 + rng.normal(size=chain.n) * 0.15
            q = np.clip(q, chain.lower, chain.upper)
            body.reset(q)
            scene.update(0.15 * k)
            client.performCollisionDetection()
            F = chain.frames(q)
            origins = F[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3]
            boxes = body.link_boxes(origins)
            # the boxes hold the links as PyBullet places them
            links = client.getLinkStates(body.body_id, list(range(21)))
            pos = np.array([s[4] for s in links])
            np.testing.assert_allclose(pos, origins, atol=1e-6)
            for horizon in (0.03, 0.1, 0.5, 1.0):
                plain = scene.clearance(body.body_id, horizon)
                fast = scene.clearance(body.body_id, horizon, robot_boxes=boxes)
                assert fast == plain, (k, horizon)
                seen["negative" if plain < 0 else "horizon" if plain == horizon else "staged"] += 1
        assert min(seen.values()) > 0, seen  # every branch was exercised
    finally:
        client.disconnect()


def test_far_obstacles_cost_no_query():
    """500 obstacles far from the robot: no getClosestPoints at all, and the horizon comes back."""
    chain = jpl_serpentine()
    data = load_world(ROOT / "worlds" / "paper_truss.json").to_dict()
    data["obstacles"] = [{"type": "sphere", "center": [float(x), 8.0, 1.0], "radius": 0.05}
                         for x in np.linspace(-3, 3, 500)]
    world = world_from_dict(data)
    client = direct_client()
    try:
        T0 = world.robot.base.transform()
        body = RobotBody.build(client, chain, T0)
        body.reset(world.robot.q0)
        scene = Scene.build(client, world)
        client.performCollisionDetection()
        F = chain.frames(chain.check(world.robot.q0))
        boxes = body.link_boxes(F[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3])
        calls = []

        class Counting:
            def __getattr__(self, name):
                if name == "getClosestPoints":
                    calls.append(name)
                return getattr(client, name)

        scene.client = Counting()
        assert scene.clearance(body.body_id, 0.5, robot_boxes=boxes) == 0.5
        assert calls == []
        assert scene.clearance(body.body_id, 0.5) == 0.5
        assert len(calls) == 4 * len(scene.body_ids)
    finally:
        client.disconnect()


def test_link_boxes_need_radii_and_shapes():
    chain = jpl_serpentine()
    client = direct_client()
    try:
        body = RobotBody.build(client, chain)
        assert body.link_radii.shape == (21,)
        assert body.link_radii[-1] == 0.0
        lo, hi = body.link_boxes(np.zeros((21, 3)))
        assert lo.shape == hi.shape == (20, 3)
        bare = RobotBody(client=client, body_id=body.body_id, chain=chain, base_transform=np.eye(4))
        with pytest.raises(ValueError, match="link_radii"):
            bare.link_boxes(np.zeros((21, 3)))
        scene = Scene.build(client, load_world(ROOT / "worlds" / "paper_truss.json"))
        with pytest.raises(ValueError, match="robot_boxes"):
            scene.clearance(body.body_id, 0.5, robot_boxes=(np.zeros((20, 2)), np.zeros((20, 2))))
    finally:
        client.disconnect()


def test_a_horizon_beyond_a_metre_still_sees_what_lies_within_it():
    """The box test culls a body only beyond the horizon asked for, whatever it is: a sphere 1.5 m above the
    robot is found at horizons of 2 and 3 m, with the link boxes as without them."""
    chain = jpl_serpentine()
    data = load_world(ROOT / "worlds" / "paper_truss.json").to_dict()
    world = world_from_dict(data)
    T0 = world.robot.base.transform()
    F = chain.frames(chain.check(world.robot.q0))
    origins = F[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3]
    top = origins[np.argmax(origins[:, 2])]
    data["obstacles"] = [{"type": "sphere", "center": (top + [0.0, 0.0, 1.6]).tolist(), "radius": 0.05}]
    client = direct_client()
    try:
        body = RobotBody.build(client, chain, T0)
        body.reset(world.robot.q0)
        scene = Scene.build(client, world_from_dict(data))
        client.performCollisionDetection()
        boxes = body.link_boxes(origins)
        for horizon in (2.0, 3.0):
            plain = scene.clearance(body.body_id, horizon)
            assert 1.4 < plain < 1.55
            assert scene.clearance(body.body_id, horizon, robot_boxes=boxes) == plain
        assert scene.clearance(body.body_id, 1.0, robot_boxes=boxes) == 1.0
    finally:
        client.disconnect()


def test_the_capsules_read_from_pybullet_are_the_robots_own():
    """What the scene reads from PyBullet's shape data and link states when a caller gives no capsules (touching,
    the pictures' red links) is the robot of interfaces.md section 1 (RobotBody.capsules, from the kinematics)."""
    from navstack.sim.scene import _link_capsules

    chain = jpl_serpentine()
    world = load_world(ROOT / "worlds" / "paper_truss.json")
    T0 = world.robot.base.transform()
    rng = np.random.default_rng(3)
    client = direct_client()
    try:
        body = RobotBody.build(client, chain, T0, serpentine_radius=0.03, arm_radius=0.07)
        for _ in range(5):
            q = np.clip(chain.check(world.robot.q0) + rng.normal(size=chain.n) * 0.3, chain.lower, chain.upper)
            body.reset(q)
            origins = chain.frames(q)[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3]

            def rows(a, b, r):  # per capsule its radius and its ends, the lower first; sorted (keys to 1 um)
                out = []
                for x, y, rk in zip(a, b, r, strict=True):
                    lo, hi = sorted([x, y], key=lambda e: tuple(np.round(e, 6)))
                    out.append((float(rk), *lo, *hi))
                return sorted(out, key=lambda row: tuple(np.round(row, 6)))

            own, read = rows(*body.capsules(origins)), rows(*_link_capsules(client, body.body_id, {}))
            assert len(read) == len(own) == 12  # six arm capsules, six serpentine links
            np.testing.assert_allclose(np.array(read), np.array(own), atol=1e-9)
    finally:
        client.disconnect()
