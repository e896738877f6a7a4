"""``bend-clutter``: a bend round a column, clutter on its inside and outside; goals before and after it.

The way: straight ahead from the tip for 0.35-0.5 m, a circular bend of radius R by an angle theta towards a
random direction across the heading (up, down, sideways or oblique), then straight for 0.15-0.25 m.  The
bend goes round a column (a cylinder across the bend's plane, radius 0.1-0.2 m, 0.6-1 m long) whose
surface is g from the bend's middle on its inside, and along a plate (0.02-0.04 m thick) tangent to
the bend's middle on its outside, g from the path.  Clutter (cables of radius 5-10 mm, spheres of radius
0.02-0.06 m, small boxes) stands beside the bend, alternately on its inside and its outside (in the
bend's plane, tilted up to 27 deg out of it), its surface 17 mm + U(0, s) from the tip's path.

Goals: only one at the start of the bend region (on the straight, 0.05-0.12 m before the bend starts)
and the destination at the end.  The spline through the goals alone cuts the corner into the column
(candidates where it does not are discarded).  The reference path is the straight-arc-straight curve
itself, sampled every 5 cm as via points (the spline through them keeps a radius near R).

Difficulty d (0..1): R from [0.36, 0.45] m down to [0.3, 0.36] m; theta from 60-85 deg up to 80-110 deg;
g 0.07 - 0.015 d m (plus up to 1 cm); 2 + round(3 d) clutter items, s = 0.01 + 0.03 (1 - d) m.
Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import HEADING, TIP, Candidate, make_guard, place
from navstack.generate.checks import CheckConfig, RobotStart, path_samples
from navstack.generate.geometry import FloatArray, cylinder_dict, perpendicular, sphere_dict
from navstack.generate.sparse import BLOCKED_DEPTH, SPARSE_CHECKS, box_on_axes, cross_axes, sparse_config

__all__ = ["bend_path", "family_bend_clutter"]


def bend_path(straight: float, radius: float, angle: float, after: float, b: FloatArray,
              step: float = 0.05) -> tuple[FloatArray, FloatArray, float, float]:
    """Samples (every ``step`` [m]) of the way: ``straight`` along the heading, an arc of ``radius`` by
    ``angle`` [rad] towards the unit ``b``, ``after`` straight; with the arc's centre, and the arc lengths
    [m] where the bend starts and ends."""
    h = HEADING
    centre = TIP + straight * h + radius * b
    total = straight + radius * angle + after
    s = np.append(np.arange(0.0, total, step), total)
    out = []
    for v in s:
        if v <= straight:
            out.append(TIP + v * h)
        elif v <= straight + radius * angle:
            phi = (v - straight) / radius
            out.append(centre + radius * (np.sin(phi) * h - np.cos(phi) * b))
        else:
            end = centre + radius * (np.sin(angle) * h - np.cos(angle) * b)
            out.append(end + (v - straight - radius * angle) * (np.cos(angle) * h + np.sin(angle) * b))
    return np.array(out), centre, straight, straight + radius * angle


def _item(rng: np.random.Generator, p: FloatArray, n: FloatArray, dist: float) -> dict[str, Any]:
    """A cable, sphere or small box whose surface is ``dist`` [m] from ``p`` along the unit ``n``."""
    kind = rng.choice(["cable", "sphere", "box"])
    if kind == "cable":
        r = rng.uniform(0.005, 0.01)
        axis = perpendicular(rng, n)
        length = rng.uniform(0.3, 0.8)
        c = p + (dist + r) * n + axis * rng.uniform(-0.2, 0.2) * length
        return cylinder_dict(c - axis * length / 2, c + axis * length / 2, r)
    if kind == "sphere":
        r = rng.uniform(0.02, 0.06)
        return sphere_dict(p + (dist + r) * n, r)
    half = rng.uniform(0.02, 0.06, size=3)
    axis = perpendicular(rng, n)
    axes = np.column_stack([n, axis, np.cross(n, axis)])
    return box_on_axes(p + (dist + half[0]) * n, axes, half)


def _structure(rng: np.random.Generator, centre: FloatArray, radius: float, angle: float, b: FloatArray,
               a: FloatArray, gap: float) -> list[dict[str, Any]]:
    """The column inside the bend and the plate outside it, each ``gap`` [m] from the bend's middle."""
    h = HEADING
    mid = np.sin(angle / 2) * h - np.cos(angle / 2) * b  # from the arc's centre to the bend's middle
    tangent = np.cos(angle / 2) * h + np.sin(angle / 2) * b
    rc = rng.uniform(0.1, 0.2)
    cc = centre + (radius - gap - rc) * mid
    half_a = rng.uniform(0.3, 0.5)
    column = cylinder_dict(cc - half_a * a, cc + half_a * a, rc)
    thick = rng.uniform(0.02, 0.04)
    pc = centre + (radius + gap + thick / 2) * mid
    half_t = radius * np.sin(angle / 2) + rng.uniform(0.05, 0.15)
    plate = box_on_axes(pc, np.column_stack([mid, tangent, np.cross(mid, tangent)]),
                        (thick / 2, half_t, rng.uniform(0.3, 0.5)))
    return [column, plate]


def family_bend_clutter(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                        robot: RobotStart) -> Candidate:
    """A cluttered bend (module docstring) ahead of the demo robot ``robot``."""
    cfg = sparse_config(cfg)
    radius = rng.uniform(0.36 - 0.06 * difficulty, 0.45 - 0.09 * difficulty)
    angle = np.radians(rng.uniform(60.0 + 20.0 * difficulty, 85.0 + 25.0 * difficulty))
    b, a = cross_axes(HEADING, rng.uniform(0.0, 2.0 * np.pi))  # b: the turn's direction, a: across the plane
    straight, after = rng.uniform(0.35, 0.5), rng.uniform(0.15, 0.25)
    gap = 0.07 - 0.015 * difficulty + rng.uniform(0.0, 0.01)
    points, centre, s0, s1 = bend_path(straight, radius, angle, after, b)
    via = points[1:]
    entry = TIP + (straight - rng.uniform(0.05, 0.12)) * HEADING
    goals = np.array([entry, via[-1]])
    structure = _structure(rng, centre, radius, angle, b, a, gap)
    S = path_samples(robot, via, cfg)
    guard = make_guard([S], goals, robot, cfg, extra=0.002)
    need = robot.serpentine_radius + cfg.path_margin + 0.002
    spread = 0.01 + 0.03 * (1.0 - difficulty)
    bend = np.flatnonzero((S.path.arc >= s0 - 0.1) & (S.path.arc <= s1 + 0.1))
    count = 2 + int(round(3 * difficulty))

    def clutter(side: float) -> dict[str, Any]:
        p = S.path.points[int(rng.choice(bend))]
        radial = p - centre
        radial -= (radial @ a) * a
        n = side * radial / np.linalg.norm(radial) + rng.uniform(-0.5, 0.5) * a
        return _item(rng, p, n / np.linalg.norm(n), need + rng.uniform(0.0, spread))

    items: list[dict[str, Any]] = []
    for k in range(count):  # outside (away from the arc's centre), inside, outside, ...
        side = 1.0 if k % 2 == 0 else -1.0
        items += place(rng, lambda side=side: clutter(side), 1, guard)
    params = {
        "bend_radius": round(float(radius), 4), "bend_deg": round(float(np.degrees(angle)), 3),
        "turn_direction": [round(float(v), 5) for v in b], "straight": round(float(straight), 4),
        "after": round(float(after), 4), "gap": round(float(gap), 4), "clutter": len(items),
    }
    desc = (f"Bend clutter: the way turns {params['bend_deg']:.0f} deg (radius {radius:.2f} m) round a column, "
            f"along a plate on the outside, with {len(items)} unmodelled item(s) beside the bend on its inside "
            f"and outside.  Goals: one where the bend region starts and the destination after it.")
    return Candidate(obstacles=structure + items, goals=goals, via=via, structure=len(structure), params=params,
                     description=desc, checks=dict(SPARSE_CHECKS), blocked_depth=BLOCKED_DEPTH)

