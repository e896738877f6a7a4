"""The robot's own arm on a planned path: a plan that turns back into the arm is refused.

The serpentine follows the tip's path and the arm follows the serpentine's first joint (the flange,
J6), so the arm sweeps along the path behind the body.  A tip path that turns back towards where it came
from (a goal behind the one before it: a loop round to it) carries the serpentine into the arm: PyBullet's
robot has no self-collision, so nothing else would see it (a loop round in an empty world went 44 mm into
the arm's second link and called itself a success).  This module checks a plan against the arm as the
search models it: the arm at the start (:class:`~navstack.planner.search.ArmShape`), translated with the
flange, which lies ``links * link_length`` behind the tip along the path.

Obstacle geometry is not read: only the robot's own path and arm.  Units: metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.planner.search import ArmShape
from navstack.validate import integer, positive

__all__ = ["OwnArmConfig", "turns_into_arm"]


@dataclass(frozen=True)
class OwnArmConfig:
    """How near the serpentine may come to its own arm on a plan.

    The serpentine's link length and radius are the search's and the repulsion's (the caller passes them).

    Attributes:
        links: serpentine links from the flange to the tip.
        margin: clearance kept between the serpentine's and the arm's surfaces [m].
        skip: the serpentine within this arc length [m] of the flange is not checked (it joins the arm there).
        spacing: the path is checked every ``spacing`` [m], and the flange's places along it too.
    """

    links: int = 6
    margin: float = 0.01
    skip: float = 0.3
    spacing: float = 0.02

    def __post_init__(self) -> None:
        positive(self, "margin", "skip", "spacing")
        integer(self, "links", lo=1)


def _resample(points: NDArray[np.float64], spacing: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points every ``spacing`` [m] along the polyline ``points`` and their arc lengths (from its start)."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.append(np.arange(0.0, arc[-1], spacing), arc[-1])
    return np.column_stack([np.interp(s, arc, points[:, i]) for i in range(3)]), s


def turns_into_arm(history: ArrayLike, plan_points: ArrayLike, arm: ArmShape, link_length: float,
                   body_radius: float, config: OwnArmConfig | None = None) -> bool:
    """Whether following ``plan_points`` brings the serpentine within ``config.margin`` of the arm.

    Args:
        history: (m, 3) the tip's path up to the plan's start, oldest first [m]; at least the body's length
            (the serpentine lies along it).
        plan_points: (n, 3) the plan's samples, ``plan_points[0]`` its start (= ``history[-1]``) [m].
        arm: the arm at the trial's start; at each moment it is taken translated by the flange's displacement.
        link_length: the serpentine's link length [m] (``SearchConfig.link_length``).
        body_radius: the serpentine capsules' radius [m] (``Repulsion.body_radius``).
        config: the clearances (``None`` = defaults).

    The serpentine at path arc length ``s`` is there while the flange is between ``s - body_length`` and ``s``
    (and not past the plan's end less the body's length); each path point from ``body_length`` before the
    plan's start on is checked against the arm at those flange places, except within ``skip`` of the flange.
    """
    cfg = config or OwnArmConfig()
    body_length = cfg.links * link_length  # from the flange to the tip [m]
    plan = np.asarray(plan_points, dtype=np.float64).reshape(-1, 3)
    path = np.vstack([np.asarray(history, dtype=np.float64).reshape(-1, 3), plan[1:]])
    if len(path) < 2:
        return False
    pts, s = _resample(path, cfg.spacing)
    start = s[-1] - float(np.linalg.norm(np.diff(plan, axis=0), axis=1).sum())  # the plan's start, as arc length
    # where the flange goes while the plan is followed: from where it is now to the plan's end less the body
    f = np.flatnonzero((s >= start - body_length - 1e-9) & (s <= s[-1] - body_length))
    if not len(f):
        return False
    # every (flange place, path point) pair with the serpentine there then: between skip and its length ahead
    i = np.minimum(f[:, None] + np.arange(int(np.ceil(body_length / cfg.spacing)) + 2)[None, :], len(s) - 1)
    ahead = s[i] - s[f][:, None]
    on = (ahead >= cfg.skip) & (ahead <= body_length) & (s[i] >= start - body_length + cfg.skip)
    rel = pts[i[on]] - pts[np.broadcast_to(f[:, None], i.shape)[on]]  # the body point from the flange
    arm_rel = arm.points - arm.flange  # the arm from the flange (it moves with it)
    reach = arm.radius + body_radius + cfg.margin
    box = np.all((rel >= arm_rel.min(axis=0) - reach) & (rel <= arm_rel.max(axis=0) + reach), axis=1)
    if not box.any():
        return False
    d = np.linalg.norm(rel[box][:, None, :] - arm_rel[None, :, :], axis=2)
    return bool(d.min() < reach)
