"""Property-based test of the world loader and the start check (Hypothesis; issue 8).

Random mutations of a valid world file (numbers replaced by extremes, NaN, infinities, huge and tiny
values; keys dropped, added or renamed; values of another type; obstacles put around or onto the robot)
must never raise anything but a ``WorldError`` naming the file, never load a world outside the documented
bounds, and never let a robot that starts inside an obstacle pass the start check.  Only loading, the
reach check and the start check run per example (no trials), so 500 examples take seconds.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from _worlds import FAR, TIP, world_data
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from navstack import world as W
from navstack.jpl import jpl_serpentine
from navstack.trial import check_reach, check_start
from navstack.world import Box, Cylinder, Mesh, Sphere, World, WorldError, load_world

HUGE_LITERAL = 424242.4242  # written into the file as 1e400 (overflows a float)

EXTREMES = [0, -0.0, 1, -1, 0.5, 0.51, 1e-9, 1e-308, 5e-324, 1e3, 1000.0001, -1000.0001, 3600, 3600.0001,
            2 * math.pi + 1e-6, 1e16, 2**53 + 1, 2**63, 10**30, 1e308, -1e308, float("nan"), float("inf"),
            float("-inf"), HUGE_LITERAL]
OTHER_VALUES = [None, True, False, "", "x", "1.0", "../outside.stl", "/dev/zero", "parts", [], {}, [1, 2],
                [0, 0, 0], [1e308, 0, 0], [[0, 0, 0]], {"type": "linear"}, {"a": 1},
                {"type": "oscillate", "axis": [0, 0, 1], "amplitude": 0.1, "period": 1.0}]
KEYS = ["type", "motion", "velocity", "axis", "amplitude", "period", "phase", "start", "stop", "center",
        "radius", "half_extents", "rpy", "p0", "p1", "path", "position", "scale", "tolerance", "extra",
        "family", "q0", "base", "colour", "time_limit", "Radius", ""]

values = st.one_of(st.sampled_from(EXTREMES), st.sampled_from(OTHER_VALUES),
                   st.floats(allow_nan=True, allow_infinity=True),
                   st.integers(-(10**20), 10**20)).map(copy.deepcopy)  # never share a mutable constant


def _base_document() -> dict:
    d = world_data({"type": "cylinder", "p0": (TIP + [0.2, 0.3, -0.3]).tolist(),
                    "p1": (TIP + [0.2, 0.3, 0.3]).tolist(), "radius": 0.02},
                   {"type": "box", "center": (TIP + [0.3, -0.4, 0.0]).tolist(), "half_extents": [0.1, 0.1, 0.2],
                    "rpy": [0.1, 0.2, 0.3]},
                   {"type": "sphere", "center": (TIP + [0.6, 0.0, 0.5]).tolist(), "radius": 0.1,
                    "motion": {"type": "linear", "velocity": [0.0, 0.0, -0.05], "start": 1.0, "stop": 3.0}},
                   {"type": "box", "center": (TIP + [0.5, 0.5, 0.0]).tolist(), "half_extents": [0.05, 0.05, 0.05],
                    "motion": {"type": "oscillate", "axis": [0, 1, 0], "amplitude": 0.1, "period": 4.0}},
                   {"type": "mesh", "path": "parts/node.stl", "position": (TIP + [0.0, 0.0, -0.8]).tolist(),
                    "rpy": [0.0, 0.0, 0.5], "scale": 2.0},
                   time_limit=30.0)
    d["goals"].insert(0, {"position": (TIP + [0.2, 0.0, 0.0]).tolist(), "tolerance": 0.03})
    d.update(description="property test", family="fuzz", extra={"seed": 1, "notes": ["a", {"b": None}]})
    return d


BASE_DOCUMENT = _base_document()


def _robot_points(world: World) -> np.ndarray:
    """Frame origins 1..21 at q0 and the midpoints between them (world frame, m): on the robot's axis."""
    T0 = world.robot.base.transform()
    origins = jpl_serpentine().frames(world.robot.q0)[1:, :3, 3] @ T0[:3, :3].T + T0[:3, 3]
    return np.vstack([origins, (origins[1:] + origins[:-1]) / 2])


ROBOT_POINTS = _robot_points(W.world_from_dict(BASE_DOCUMENT | {"obstacles": [FAR]}))


def _locations(doc) -> list[tuple[object, object]]:
    """Every (container, key) in the document, depth first."""
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc)
    for k, v in list(items):
        out.append((doc, k))
        if isinstance(v, (dict, list)):
            out.extend(_locations(v))
    return out


@st.composite
def enclosing_obstacles(draw) -> dict:
    """An obstacle around or touching a point of the robot at q0, maybe moving."""
    p = ROBOT_POINTS[draw(st.integers(0, len(ROBOT_POINTS) - 1))]
    size = draw(st.one_of(st.sampled_from([1e-4, 0.01, 0.05, 0.5, 10.0, 999.0, 1000.0, 1e308]),
                          st.floats(1e-4, 1000.0)))
    offset = draw(st.sampled_from([0.0, 0.01, 0.1])) * np.array([0.0, 1.0, 0.0])
    kind = draw(st.sampled_from(["sphere", "box", "cylinder"]))
    c = (p + offset).tolist()
    if kind == "sphere":
        o = {"type": "sphere", "center": c, "radius": size}
    elif kind == "box":
        o = {"type": "box", "center": c, "half_extents": [size] * 3, "rpy": [0.3, 0.0, 0.0]}
    else:
        o = {"type": "cylinder", "p0": (p - [0, 0, size]).tolist(), "p1": (p + [0, 0, size]).tolist(), "radius": size}
    if draw(st.booleans()):
        o["motion"] = copy.deepcopy(draw(st.sampled_from([
            {"type": "linear", "velocity": [0.0, 0.1, 0.0], "start": 2.0},
            {"type": "oscillate", "axis": [1, 0, 0], "amplitude": 0.05, "period": 5.0}])))
    return o


@st.composite
def mutated_documents(draw) -> dict:
    doc = copy.deepcopy(BASE_DOCUMENT)
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["number", "number", "value", "drop", "add", "rename", "enclose", "move-onto"]))
        if kind == "enclose":
            obstacles = doc.get("obstacles")
            if isinstance(obstacles, list):
                obstacles.insert(draw(st.integers(0, len(obstacles))), draw(enclosing_obstacles()))
            continue
        if kind == "move-onto":
            obstacles = doc.get("obstacles")
            obstacles = obstacles if isinstance(obstacles, list) else []
            prims = [o for o in obstacles if isinstance(o, dict) and "center" in o]
            if prims:
                point = ROBOT_POINTS[draw(st.integers(0, len(ROBOT_POINTS) - 1))]
                draw(st.sampled_from(prims))["center"] = point.tolist()
            continue
        locations = _locations(doc)
        if kind == "number":  # a number replaced by another (extreme, NaN, huge, tiny, negative, ...)
            numbers = [(c, k) for c, k in locations if isinstance(c[k], (int, float)) and not isinstance(c[k], bool)]
            locations, kind = numbers or locations, "value"
        parent, key = draw(st.sampled_from(locations))
        if kind == "value":
            parent[key] = draw(values)
        elif kind == "drop":
            del parent[key]
        elif kind == "add":
            if isinstance(parent, dict):
                parent[draw(st.sampled_from(KEYS))] = draw(values)
            else:
                parent.insert(key, draw(values))
        elif isinstance(parent, dict):  # rename
            parent[draw(st.sampled_from(KEYS))] = parent.pop(key)
    return doc


def _inside(points: np.ndarray, o, eps: float = 1e-9) -> bool:
    """True if any point is strictly inside the primitive ``o`` at t = 0 (analytic, independent of PyBullet)."""
    d0 = o.motion.displacement(0.0) if o.motion is not None else np.zeros(3)
    if isinstance(o, Sphere):
        return bool(np.any(np.linalg.norm(points - (o.center + d0), axis=1) < o.radius - eps))
    if isinstance(o, Box):
        local = (points - (o.center + d0)) @ Rotation.from_euler("xyz", o.rpy).as_matrix()
        return bool(np.any(np.all(np.abs(local) < o.half_extents - eps, axis=1)))
    u = (o.p1 - o.p0) / o.length
    rel = points - (o.p0 + d0)
    s = rel @ u
    radial = np.linalg.norm(rel - np.outer(s, u), axis=1)
    return bool(np.any((s > eps) & (s < o.length - eps) & (radial < o.radius - eps)))


def _assert_within_bounds(w: World) -> None:
    """The documented bounds of navstack/world.py, checked on what was loaded."""
    coords = [w.robot.base.position, *(g.position for g in w.goals)]
    angles = [w.robot.base.rpy]
    for o in w.obstacles:
        if isinstance(o, Cylinder):
            coords += [o.p0, o.p1]
            assert W.MIN_LENGTH <= o.radius <= W.MAX_LENGTH and o.length >= W.MIN_LENGTH
        elif isinstance(o, Sphere):
            coords.append(o.center)
            assert W.MIN_LENGTH <= o.radius <= W.MAX_LENGTH
        elif isinstance(o, Box):
            coords.append(o.center)
            angles.append(o.rpy)
            assert np.all((o.half_extents >= W.MIN_LENGTH) & (o.half_extents <= W.MAX_LENGTH))
        else:
            assert isinstance(o, Mesh) and W.MIN_MESH_SCALE <= o.scale <= W.MAX_MESH_SCALE
            coords.append(o.position)
            angles.append(o.rpy)
        motion = getattr(o, "motion", None)
        if isinstance(motion, W.LinearMotion):
            assert np.linalg.norm(motion.velocity) <= W.MAX_OBSTACLE_SPEED and 0 <= motion.start <= motion.stop
        elif motion is not None:
            assert motion.peak_speed <= W.MAX_OBSTACLE_SPEED and np.linalg.norm(motion.axis) > 0
    assert np.all(np.abs(np.concatenate(coords)) <= W.MAX_COORDINATE)
    assert np.all(np.abs(np.concatenate(angles)) <= W.MAX_ANGLE + 1e-9)
    assert 0 < w.time_limit <= W.MAX_TIME_LIMIT
    assert all(W.MIN_TOLERANCE <= g.tolerance <= W.MAX_TOLERANCE for g in w.goals)
    for r in (w.robot.serpentine_radius, w.robot.arm_radius):
        assert W.MIN_ROBOT_RADIUS <= r <= W.MAX_ROBOT_RADIUS
    assert 1 <= len(w.goals) <= W.MAX_GOALS and len(w.obstacles) <= W.MAX_OBSTACLES


@pytest.fixture(scope="module")
def world_file(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "parts").mkdir()
    trimesh.creation.box(extents=(0.2, 0.2, 0.2)).export(folder / "parts" / "node.stl")
    return folder / "world.json"


def test_the_base_document_is_valid_and_starts_clear(world_file):
    world_file.write_text(json.dumps(BASE_DOCUMENT))
    w = load_world(world_file)
    check_reach(w)
    check_start(w)
    assert not any(_inside(_robot_points(w), o) for o in w.obstacles if not isinstance(o, Mesh))


@settings(max_examples=500, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(doc=mutated_documents())
def test_mutated_worlds_are_refused_cleanly_or_start_clear(world_file, doc):
    text = json.dumps(doc).replace(repr(HUGE_LITERAL), "1e400")  # NaN / Infinity literals stay as written
    world_file.write_text(text)
    try:
        w = load_world(world_file)  # anything but a WorldError is a traceback: the test fails
    except WorldError as e:
        assert str(e).startswith(f"{world_file}: ") and e.detail
        event("refused when loaded")
        return
    _assert_within_bounds(w)
    try:
        check_reach(w)
        check_start(w)
    except WorldError as e:
        assert e.json_path.startswith(("goals[", "obstacles[")) and str(e).startswith(f"{world_file}: ")
        event(f"refused by the {'start' if e.json_path.startswith('obstacles[') else 'reach'} check")
        return
    event("accepted")
    # accepted: no point of the robot may be inside any primitive at t = 0
    points = _robot_points(w)
    inside = [i for i, o in enumerate(w.obstacles) if not isinstance(o, Mesh) and _inside(points, o)]
    assert not inside, f"the start check let the robot start inside obstacles {inside}"
