"""``truss`` and ``cluttered-truss``: the paper's box-bay truss displaced from its drawing, goals at every opening.

``truss``
    The paper's box-bay truss (1 or 2 x 3 x 2 bays) placed so that an opening of the middle upper
    bay's front face (bottom-right or top-left triangle) is ``standoff`` ahead of the tip.  A random
    manoeuvre: ``climb`` (in, up on an arc of radius R, out through the top face: the paper's),
    ``through`` (straight through the bay and out of the back face, or into the second bay), or
    ``side`` (turn on a horizontal arc through the side face into the neighbouring bay).  Goals are
    drawn in the truss's *drawing*; the actual truss is displaced by a random error (offset up to
    0.06 m x difficulty, rotation up to 3 deg x difficulty about the entry opening's centre), and
    difficulty shrinks the bay side (0.5 -> 0.42 m) and grows the member radius (0.02 -> 0.025 m).
    The reference via points are the goals moved towards the *actual* truss by at most 90 % of their
    tolerance (the path a robot that senses the truss can take).
``cluttered-truss``
    As ``truss`` plus unmodelled cables (cylinders of radius 0.005-0.01 m) and equipment boxes placed
    near the path (more, and closer, with difficulty), never within the clearance the slithering body
    needs around the drawn path or the reference path.

Units: metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from navstack.generate.base import (
    HEADING,
    TIP,
    TOLERANCE,
    Candidate,
    cable,
    equipment,
    make_guard,
    place,
)
from navstack.generate.checks import CheckConfig, ReferencePath, RobotStart, path_samples
from navstack.generate.geometry import FloatArray, cylinder_dict, rounded, unit_vector
from navstack.truss import incircle_offset, truss_members

__all__ = [
    "TrussLayout",
    "draw_truss",
    "family_cluttered_truss",
    "family_truss",
    "gen_truss",
    "reachable_via",
    "truss_candidate",
    "truss_goals",
]


@dataclass(frozen=True)
class TrussLayout:
    """A truss world as drawn and as built.

    Attributes:
        side: bay side [m]; member_radius [m]; bays (nx, ny, nz).
        standoff: distance [m] from the start tip to the entry opening's centre.
        entry: ``"br"`` (bottom-right triangle of the front face) or ``"tl"`` (top-left).
        manoeuvre: ``"climb"``, ``"through"`` or ``"side"``.
        goals_local: (k, 3) goals [m] in the entry bay's frame (front face x = 0, bay [0, side]^3).
        offset: displacement [m] of the actual truss from its drawing.
        rpy: rotation [rad] of the actual truss about the entry opening's centre (roll X, pitch Y, yaw Z).
    """

    side: float
    member_radius: float
    bays: tuple[int, int, int]
    standoff: float
    entry: str
    manoeuvre: str
    goals_local: FloatArray
    offset: FloatArray
    rpy: FloatArray

    def entry_point(self) -> FloatArray:
        """Centre of the entry opening in the entry bay's frame [m]."""
        c = incircle_offset(self.side)
        s = self.side
        return np.array([0.0, s - c, c]) if self.entry == "br" else np.array([0.0, c, s - c])

    def to_local(self, points: FloatArray) -> FloatArray:
        """Points (N, 3) [m] near the *actual* truss in the truss's own frame (corner (0, 0, 0), bays
        [0, nx side] x [0, ny side] x [0, nz side]): the inverse of the displacement, then the drawing."""
        ny, nz = self.bays[1], self.bays[2]
        entry_local = np.array([0, ny // 2, nz - 1], dtype=float) * self.side + self.entry_point()
        origin = TIP + self.standoff * HEADING - entry_local
        pivot = origin + entry_local
        R = Rotation.from_euler("xyz", self.rpy).as_matrix()
        return (np.asarray(points) - pivot - self.offset) @ R + pivot - origin

    def build(self) -> tuple[list[dict[str, Any]], list[dict[str, Any]], FloatArray, FloatArray]:
        """Actual members, drawn members, goals (drawn, world) and the goals carried with the actual truss."""
        nx, ny, nz = self.bays
        entry_bay = np.array([0, ny // 2, nz - 1], dtype=float) * self.side
        entry_local = entry_bay + self.entry_point()
        origin = TIP + self.standoff * HEADING - entry_local
        pivot = origin + entry_local
        R = Rotation.from_euler("xyz", self.rpy).as_matrix()
        goals = self.goals_local + entry_bay + origin
        moved = (goals - pivot) @ R.T + pivot + self.offset
        actual, drawn = [], []
        for p0, p1 in truss_members(self.bays, self.side):
            a, b = origin + p0, origin + p1
            drawn.append(cylinder_dict(a, b, self.member_radius))
            actual.append(cylinder_dict(R @ (a - pivot) + pivot + self.offset, R @ (b - pivot) + pivot + self.offset,
                               self.member_radius))
        return actual, drawn, goals, moved


def truss_goals(rng: np.random.Generator, side: float, entry: str, manoeuvre: str, nx: int) -> FloatArray:
    """Goals in the entry bay's frame for one manoeuvre (see the module docstring)."""
    c = incircle_offset(side)
    y_e, z_e = (side - c, c) if entry == "br" else (c, side - c)
    approach = np.array([-rng.uniform(0.1, 0.2), y_e, z_e])
    if manoeuvre == "through":
        mid = np.array([side / 2 + rng.uniform(-0.05, 0.05), y_e + rng.uniform(-0.02, 0.02),
                        z_e + rng.uniform(-0.02, 0.02)])
        depth = side + rng.uniform(0.12, 0.25) if nx == 1 else side + rng.uniform(0.2, 0.3)
        end = np.array([depth, y_e + rng.uniform(-0.03, 0.03), z_e + rng.uniform(-0.03, 0.03)])
        return np.array([approach, mid, end])
    # arc radius R from x = a; the turn must end >= ~0.09 m before the back face x = side
    room = side - 0.09
    R = rng.uniform(0.28, min(0.36, room)) if manoeuvre == "climb" else rng.uniform(0.3, min(0.38, room))
    a = rng.uniform(0.0, max(0.0, min(0.06, room - R)))
    phi1 = np.radians(rng.uniform(18.0, 32.0))
    phi2 = np.radians(rng.uniform(55.0, 72.0))
    if manoeuvre == "climb":
        arc = [np.array([a + R * np.sin(p), y_e, z_e + R * (1 - np.cos(p))]) for p in (phi1, phi2)]
        top = max(side + rng.uniform(0.12, 0.25), z_e + R + 0.03)
        # the second arc goal only where it is well inside the bay or well above it
        keep = arc if abs(arc[1][2] - side) > 0.08 else arc[:1]
        return np.array([approach, *keep, [a + R, y_e, top]])
    # side: a horizontal arc towards the near side face (y = side for "br", y = 0 for "tl"), crossing it
    # between two goals placed ~0.09 m before and after the face
    sign = 1.0 if entry == "br" else -1.0
    to_face = side - y_e if sign > 0 else y_e
    phis = [np.radians(rng.uniform(15.0, 25.0))]
    for rise in (to_face - rng.uniform(0.095, 0.11), to_face + rng.uniform(0.095, 0.12)):
        if 0.0 < rise < R:
            phi = float(np.arccos(1.0 - rise / R))
            if phi - phis[-1] < np.radians(8.0):
                phis.pop()
            phis.append(phi)
    arc = [np.array([a + R * np.sin(p), y_e + sign * R * (1 - np.cos(p)), z_e]) for p in phis]
    end = np.array([a + R, y_e + sign * (R + rng.uniform(0.08, 0.15)), z_e])
    return np.array([approach, *arc, end])


def draw_truss(rng: np.random.Generator, difficulty: float) -> TrussLayout:
    """A random truss layout: bays, manoeuvre, entry, drawn goals and the displacement (module docstring)."""
    side = round(0.5 - 0.08 * difficulty, 4)
    member = round(0.02 + 0.005 * difficulty, 4)
    nx = 2 if rng.random() < 0.3 else 1
    manoeuvre = str(rng.choice(["climb", "through", "side"], p=[0.45, 0.2, 0.35]))
    # the top-left opening leaves too little room for a climb or a side turn of radius >= 0.25 m
    entry = "tl" if manoeuvre == "through" and rng.random() < 0.5 else "br"
    goals = truss_goals(rng, side, entry, manoeuvre, nx)
    offset = unit_vector(rng) * 0.06 * difficulty * rng.uniform(0.6, 1.0)
    angle = np.radians(3.0) * difficulty * rng.uniform(0.6, 1.0)
    rpy = Rotation.from_rotvec(unit_vector(rng) * angle).as_euler("xyz")
    return TrussLayout(side=side, member_radius=member, bays=(nx, 3, 2),
                       standoff=round(rng.uniform(0.45, 0.6), 4),
                       entry=entry, manoeuvre=manoeuvre, goals_local=goals, offset=offset, rpy=rpy)


def reachable_via(goals: FloatArray, moved: FloatArray, reach: float) -> FloatArray:
    """Goals moved towards where the actual truss carries them, by at most ``reach`` [m]."""
    d = moved - goals
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return goals + d * np.minimum(1.0, reach / np.maximum(n, 1e-12))


def truss_candidate(layout: TrussLayout, cfg: CheckConfig) -> Candidate:
    """The actual truss, the drawn goals and the reachable reference via points of ``layout``."""
    actual, drawn, goals, moved = layout.build()
    via = reachable_via(goals, moved, cfg.goal_reach * TOLERANCE - 1e-3)
    params = {
        "side": layout.side, "member_radius": layout.member_radius, "bays": list(layout.bays),
        "standoff": layout.standoff, "entry": layout.entry, "manoeuvre": layout.manoeuvre,
        "truss_offset": rounded(layout.offset), "truss_rpy": rounded(layout.rpy),
        "offset_norm": round(float(np.linalg.norm(layout.offset)), 5),
        "rotation_deg": round(float(np.degrees(Rotation.from_euler("xyz", layout.rpy).magnitude())), 4),
    }
    nx, ny, nz = layout.bays
    desc = (f"Box-bay truss ({nx}x{ny}x{nz} bays of {layout.side} m, members "
            f"of radius {layout.member_radius} m); manoeuvre '{layout.manoeuvre}' through the "
            f"{'bottom-right' if layout.entry == 'br' else 'top-left'} opening.  Goals are drawn positions; "
            f"the actual truss is displaced {params['offset_norm']:.3f} m and rotated "
            f"{params['rotation_deg']:.2f} deg "
            f"from its drawing.")
    return Candidate(obstacles=actual, goals=goals, via=via, structure=len(actual), params=params,
                      description=desc, drawn=drawn)


def gen_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig, robot: RobotStart,
               clutter: bool) -> Candidate:
    """A ``truss`` candidate, with cables and boxes near the drawn and reference paths if ``clutter``."""
    cand = truss_candidate(draw_truss(rng, difficulty), cfg)
    if not clutter:
        return cand
    s_ref = path_samples(robot, cand.via, cfg)
    s_drawn = path_samples(robot, cand.goals, cfg)
    guard = make_guard([s_ref, s_drawn], cand.goals, robot, cfg)
    s_from = 0.25
    spread = 0.02 + 0.12 * (1.0 - difficulty)
    need = robot.serpentine_radius + cfg.body_margin + 0.01

    def dist() -> float:
        return need + rng.uniform(0.0, spread)

    paths = [s_ref.path, s_drawn.path]
    n_cables = 1 + int(round(3 * difficulty)) + int(rng.integers(0, 2))
    n_boxes = 1 + int(round(2 * difficulty))
    def pick() -> ReferencePath:
        return paths[int(rng.integers(0, 2))]

    cables = place(rng, lambda: cable(rng, pick(), dist(), s_from), n_cables, guard)
    boxes = place(rng, lambda: equipment(rng, pick(), dist(), s_from), n_boxes, guard)
    cand.obstacles = cand.obstacles + cables + boxes
    cand.params.update({"cables": len(cables), "boxes": len(boxes)})
    cand.description += (f"  Unmodelled clutter near the path: {len(cables)} cable(s) and {len(boxes)} "
                         f"equipment box(es).")
    return cand


def family_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig, robot: RobotStart) -> Candidate:
    """A displaced truss, goals at every opening (module docstring)."""
    return gen_truss(rng, difficulty, cfg, robot, clutter=False)


def family_cluttered_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                           robot: RobotStart) -> Candidate:
    """A displaced truss with unmodelled cables and boxes near the path (module docstring)."""
    return gen_truss(rng, difficulty, cfg, robot, clutter=True)

