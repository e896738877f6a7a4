"""Small world documents shared by the hardening, moving-obstacle and CLI tests (the paper's robot)."""

from __future__ import annotations

import numpy as np

from navstack.jpl import jpl_serpentine
from navstack.truss import paper_truss_world
from navstack.world import world_from_dict

ROBOT = paper_truss_world()["robot"]


def _tip_and_base() -> tuple[np.ndarray, np.ndarray]:
    """The tip at q0 and the base position (world frame, m) of the paper's robot placement."""
    w = world_from_dict({"format": "navstack-world/1", "name": "t", "robot": ROBOT, "obstacles": [],
                         "goals": [{"position": [1.0, 0.0, 1.0]}]})
    T0 = w.robot.base.transform()
    tip = T0[:3, :3] @ jpl_serpentine().frames(w.robot.q0)[21, :3, 3] + T0[:3, 3]
    return tip, T0[:3, 3].copy()


TIP, BASE_POSITION = _tip_and_base()
"""The tip at q0 (pointing along world +x) and the base position, m."""
FAR = {"type": "sphere", "center": (TIP + [0.0, 0.0, 1.5]).tolist(), "radius": 0.05}
"""A sphere far from the robot and its path: ``obstacles[0]`` of every :func:`world_data` world."""


def world_data(*obstacles: dict, time_limit: float = 2.0) -> dict:
    """The paper's robot, a goal 0.4 m ahead of the tip, :data:`FAR` as ``obstacles[0]``, then ``obstacles``."""
    return {"format": "navstack-world/1", "name": "hardening", "robot": ROBOT,
            "obstacles": [FAR, *obstacles], "goals": [{"position": (TIP + [0.4, 0.0, 0.0]).tolist()}],
            "time_limit": time_limit}
