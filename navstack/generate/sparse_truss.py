"""``sparse-truss``: the paper's box-bay truss with only an inspection point and an exit as goals.

The truss, its placement and its manoeuvre are those of ``truss`` (:func:`navstack.generate.truss_families.
draw_truss`: 1 or 2 x 3 x 2 bays, displaced from its drawing by up to 0.06 m x d and 3 deg x d), with the
manoeuvres ``climb`` and ``side`` only: on the way straight ``through`` the spline through an inspection
point and the exit beyond the back face is the way through the openings (it marks the way).  The
reference via points are the manoeuvre's drawn goals carried *fully* with the actual truss (in front of
the opening, through it, the turn, out of the top or side face); they are not goals.  The world's goals are only:

* an inspection point: a point of the reference path inside the truss (at least 0.07 m from every
  member), drawn among those for which the body slithering along the spline through the goals alone
  cuts into a member (``blocked_by: truss``: heading for the goals hits the truss: always for ``side``);
  where there is none (often for ``climb``: the opening lies on the way to a point low in the bay) a
  sphere of unmodelled equipment is placed across that spline, clear of the reference path
  (``blocked_by: clutter``; :func:`navstack.generate.sparse.block_goal_path`); a candidate whose
  goals-only spline stays clear of everything (truss and clutter) is discarded;
* the exit point: the last via point, above the truss (climb), beyond its back face (through) or in the
  neighbouring bay beyond the side face (side); the opening out is not marked either.

Unmodelled clutter near the reference path beyond its first 0.25 m: cables (radius 5-10 mm), spheres
(radius 0.03-0.08 m) and equipment boxes, their surfaces 17 mm + U(0, s) from the tip's path (s =
0.015 + 0.02 (1 - d) m: 1.7-5.2 cm at d = 0, 1.7-3.2 cm at d = 1), never closer than the checks allow
(12 mm for every link).

Difficulty d (0..1): the truss's (bay side 0.5 -> 0.42 m, members 0.02 -> 0.025 m, displacement); 1 +
round(2 d) (+ 0 or 1) cables, 1 + round(d) spheres and 1 + round(d) boxes, closer to the path.
Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import HEADING, TIP, Candidate, cable, equipment, make_guard, place
from navstack.generate.checks import CheckConfig, RobotStart, path_samples, reference_path
from navstack.generate.geometry import FloatArray, obstacle_distance, rounded
from navstack.generate.sparse import (
    BLOCKED_DEPTH,
    SPARSE_CHECKS,
    ball_between,
    block_goal_path,
    obstacles_of,
    sparse_config,
)
from navstack.generate.truss_families import TrussLayout, draw_truss

__all__ = ["family_sparse_truss", "inspection_point"]

INSIDE_CLEARANCE = 0.07
"""An inspection point is at least this far [m] from every member (goal clearance 0.06 m + 0.01 m)."""


def inspection_point(rng: np.random.Generator, layout: TrussLayout, actual: list[dict[str, Any]],
                     via: FloatArray, robot: RobotStart, cfg: CheckConfig) -> tuple[FloatArray, bool]:
    """A point of the reference path (through ``via``) inside the truss, at least :data:`INSIDE_CLEARANCE`
    from every member: of up to 12 random ones, the first for which the body slithering along the spline
    through (the point, the exit) cuts :data:`BLOCKED_DEPTH` into a member (True), else the one whose
    spline strays furthest from the reference path (room for a blocker, False)."""
    members = obstacles_of(actual)
    ref = reference_path(TIP, HEADING, via, 0.02)
    local = layout.to_local(ref.points)
    size = np.array(layout.bays, dtype=float) * layout.side
    inside = np.all((local > 0.0) & (local < size), axis=1)
    inside &= obstacle_distance(members, ref.points) >= INSIDE_CLEARANCE
    idx = [int(i) for i in np.flatnonzero(inside)]
    if not idx:
        return ref.points[len(ref.points) // 2], False
    best, best_sep = idx[0], -1.0
    for i in rng.permutation(idx)[:12]:
        goals = np.array([ref.points[i], via[-1]])
        spline = reference_path(TIP, HEADING, goals, 0.01)
        tip = obstacle_distance(members, spline.points).min()
        if tip <= 0.06:  # else the body cannot cut in
            body = path_samples(robot, goals, cfg).body
            if obstacle_distance(members, body).min() - robot.serpentine_radius <= -BLOCKED_DEPTH:
                return ref.points[i], True
        far = spline.points[spline.arc >= 0.25]
        sep = max((float(np.linalg.norm(ref.points - q, axis=1).min()) for q in far), default=0.0)
        if sep > best_sep:
            best, best_sep = int(i), sep
    return ref.points[best], False


def family_sparse_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                        robot: RobotStart) -> Candidate:
    """A goal-only truss (module docstring) ahead of the demo robot ``robot``."""
    cfg = sparse_config(cfg)
    layout = draw_truss(rng, difficulty)
    while layout.manoeuvre == "through":  # an inspection point on the way straight through marks the way
        layout = draw_truss(rng, difficulty)
    actual, _, _, via = layout.build()
    point, by_truss = inspection_point(rng, layout, actual, via, robot, cfg)
    goals = np.array([point, via[-1]])
    S = path_samples(robot, via, cfg)
    guard = make_guard([S], goals, robot, cfg, extra=0.002)
    blockers = [] if by_truss else block_goal_path(rng, goals, S, guard, robot)
    spread = 0.015 + 0.02 * (1.0 - difficulty)
    need = robot.serpentine_radius + cfg.path_margin + 0.002

    def dist() -> float:
        return need + rng.uniform(0.0, spread)

    arc = S.path.arc[-1]
    cables = place(rng, lambda: cable(rng, S.path, dist(), 0.25), 1 + int(round(2 * difficulty))
                   + int(rng.integers(0, 2)), guard)
    balls = place(rng, lambda: ball_between(rng, S.path, 0.25, arc, dist(), (0.03, 0.08)),
                  1 + int(round(difficulty)), guard)
    boxes = place(rng, lambda: equipment(rng, S.path, dist(), 0.25), 1 + int(round(difficulty)), guard)
    nx, ny, nz = layout.bays
    offset = float(np.linalg.norm(layout.offset))
    params = {
        "side": layout.side, "member_radius": layout.member_radius, "bays": list(layout.bays),
        "standoff": layout.standoff, "entry": layout.entry, "manoeuvre": layout.manoeuvre,
        "truss_offset": rounded(layout.offset), "truss_rpy": rounded(layout.rpy), "offset_norm": round(offset, 5),
        "blocked_by": "truss" if by_truss else "clutter", "blockers": len(blockers), "cables": len(cables),
        "spheres": len(balls), "boxes": len(boxes),
    }
    where = {"climb": "above the truss", "through": "beyond its back face", "side": "beyond its side face"}
    desc = (f"Goal-only truss ({nx}x{ny}x{nz} bays of {layout.side} m, members of radius {layout.member_radius} m, "
            f"displaced {offset:.3f} m from its drawing) with unmodelled clutter near the way ({len(cables)} "
            f"cable(s), {len(balls)} sphere(s), {len(boxes)} box(es)).  Goals: an inspection point inside the "
            f"truss and the exit point {where[layout.manoeuvre]}; the openings in and out are not marked.")
    return Candidate(obstacles=actual + blockers + cables + balls + boxes, goals=goals, via=via, structure=len(actual),
                     params=params, description=desc, checks=dict(SPARSE_CHECKS), blocked_depth=BLOCKED_DEPTH)
