"""``dead-end``: a pocket (a box tube or a cage open on one side) with the goal at its back; retract.

The pocket's axis is tilted up to 10 + 20 d deg from the heading (towards a random direction across
it), its mouth 0.45-0.6 m of way ahead of the tip (and so shifted across the heading as much as a turn
of radius 0.35-0.5 m onto the axis shifts it), its cross-section rolled at random about the axis.  Inside:
2 hw1 x 2 hw2 (hw 0.11 - 0.03 d m, minus up to 1 cm, at least 0.075 m), 0.3 + 0.2 d m deep (+ up to
5 cm).  A box tube has four walls (10-20 mm thick) and a back plate; a cage has bars (radius 6-12 mm,
at most 4.5 cm apart surface to surface: nothing the size of the tip passes) along the axis, square rings
at the mouth, every 0.15 m and at the back, and a back of bars.

The only goal sits on the axis 0.07-0.1 m in front of the back: the robot must reach into the pocket,
and, with ``"retract": true`` (the family's default), back out along its own path to its start
(interfaces.md section 2a): the only way out is the way in.  The reference path: straight from the tip,
an arc of radius 0.35-0.5 m onto the axis ending 0.12-0.2 m in front of the mouth, then straight along
the axis to the goal (:func:`navstack.generate.bend_clutter.bend_path`); via points every 5 cm.  Up to
round(2 d) cables or spheres stand beside the approach, 17 mm + U(0, 0.03) m from the tip's path.

Difficulty d (0..1): narrower (0.11 -> 0.08 m half width) and deeper (0.3 -> 0.5 m) pockets, more tilt
(an approach that must curve into the mouth), 0 -> 2 clutter items.  Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import HEADING, TIP, Candidate, make_guard, place
from navstack.generate.bend_clutter import bend_path
from navstack.generate.checks import CheckConfig, RobotStart, path_samples
from navstack.generate.geometry import FloatArray, cylinder_dict, perpendicular
from navstack.generate.sparse import SPARSE_CHECKS, ball_between, box_on_axes, cable_between, sparse_config

__all__ = ["box_tube", "cage", "family_dead_end"]

CAGE_GAP = 0.045
"""Largest gap [m] between cage bars, surface to surface (the tip capsule is 0.05 m across)."""


def box_tube(mouth: FloatArray, axes: FloatArray, half: tuple[float, float], depth: float,
             wall: float) -> list[dict[str, Any]]:
    """Four walls and a back plate around the inside [0, depth] x [-half[0], half[0]] x [-half[1], half[1]]
    of the frame ``axes`` (columns: axis, across 1, across 2) at ``mouth`` [m]."""
    w, e1, e2 = axes.T
    h1, h2 = half
    mid = mouth + 0.5 * depth * w
    return [
        box_on_axes(mid + (h1 + wall / 2) * e1, axes, (depth / 2, wall / 2, h2 + wall)),
        box_on_axes(mid - (h1 + wall / 2) * e1, axes, (depth / 2, wall / 2, h2 + wall)),
        box_on_axes(mid + (h2 + wall / 2) * e2, axes, (depth / 2, h1, wall / 2)),
        box_on_axes(mid - (h2 + wall / 2) * e2, axes, (depth / 2, h1, wall / 2)),
        box_on_axes(mouth + (depth + wall / 2) * w, axes, (wall / 2, h1 + wall, h2 + wall)),
    ]


def _bar_offsets(half: float, radius: float) -> FloatArray:
    """Bar positions [m] across one side from -half - radius to half + radius, gaps <= :data:`CAGE_GAP`."""
    span = 2.0 * (half + radius)
    n = int(np.ceil(span / (CAGE_GAP + 2.0 * radius)))
    return np.linspace(-half - radius, half + radius, n + 1)


def cage(mouth: FloatArray, axes: FloatArray, half: tuple[float, float], depth: float,
         radius: float) -> list[dict[str, Any]]:
    """Bars of ``radius`` [m] around the same inside as :func:`box_tube`: along the axis on the four sides,
    square rings at the mouth, every 0.15 m and at the back, and a back of bars across ``axes[:, 1]``."""
    w, e1, e2 = axes.T
    h1, h2 = half
    out = []
    for s1 in _bar_offsets(h1, radius):
        for s2 in (-h2 - radius, h2 + radius):
            base = mouth + s1 * e1 + s2 * e2
            out.append(cylinder_dict(base, base + (depth + radius) * w, radius))
    for s2 in _bar_offsets(h2, radius)[1:-1]:
        for s1 in (-h1 - radius, h1 + radius):
            base = mouth + s1 * e1 + s2 * e2
            out.append(cylinder_dict(base, base + (depth + radius) * w, radius))
    rings = np.append(np.arange(0.0, depth, 0.15), depth + radius)
    for x in rings:
        c = mouth + x * w
        for s in (-1.0, 1.0):
            out.append(cylinder_dict(c + s * (h1 + radius) * e1 - (h2 + 2 * radius) * e2,
                                     c + s * (h1 + radius) * e1 + (h2 + 2 * radius) * e2, radius))
            out.append(cylinder_dict(c + s * (h2 + radius) * e2 - (h1 + 2 * radius) * e1,
                                     c + s * (h2 + radius) * e2 + (h1 + 2 * radius) * e1, radius))
    back = mouth + (depth + radius) * w
    for s2 in _bar_offsets(h2, radius)[1:-1]:
        out.append(cylinder_dict(back + s2 * e2 - (h1 + radius) * e1, back + s2 * e2 + (h1 + radius) * e1, radius))
    return out


def family_dead_end(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                    robot: RobotStart) -> Candidate:
    """A pocket (module docstring) ahead of the demo robot ``robot``; ``retract`` by default."""
    cfg = sparse_config(cfg)
    tilt = np.radians(rng.uniform(0.0, 10.0 + 20.0 * difficulty))
    b = perpendicular(rng, HEADING)  # the approach turns towards b by `tilt`
    radius = rng.uniform(0.35, 0.5)
    lead = rng.uniform(0.12, 0.2)  # straight along the axis before the mouth
    half = tuple(float(max(0.075, 0.11 - 0.03 * difficulty - rng.uniform(0.0, 0.01))) for _ in range(2))
    depth = 0.3 + 0.2 * difficulty + rng.uniform(0.0, 0.05)
    back_gap = rng.uniform(0.07, 0.1)
    straight = max(0.05, rng.uniform(0.45, 0.6) - radius * tilt - lead)
    points, _, _, _ = bend_path(straight, radius, tilt, lead + depth - back_gap, b)
    w = np.cos(tilt) * HEADING + np.sin(tilt) * b
    goal = points[-1]
    mouth = goal - (depth - back_gap) * w
    e1 = perpendicular(rng, w)
    axes = np.column_stack([w, e1, np.cross(w, e1)])
    kind = "box tube" if rng.random() < 0.6 else "cage"
    pocket = (box_tube(mouth, axes, half, depth, rng.uniform(0.01, 0.02)) if kind == "box tube"
              else cage(mouth, axes, half, depth, rng.uniform(0.006, 0.012)))
    via = points[1:]
    before = mouth - lead * w
    goals = goal[None]
    S = path_samples(robot, via, cfg)
    guard = make_guard([S], goals, robot, cfg, extra=0.002)
    need = robot.serpentine_radius + cfg.path_margin + 0.002
    s_mouth = float(S.path.arc[np.argmin(np.linalg.norm(S.path.points - before, axis=1))])

    def item() -> dict[str, Any]:
        dist = need + rng.uniform(0.0, 0.03)
        if rng.random() < 0.5:
            return cable_between(rng, S.path, 0.25, s_mouth, dist)
        return ball_between(rng, S.path, 0.25, s_mouth, dist, (0.03, 0.06))

    items = place(rng, item, int(round(2 * difficulty)), guard)
    params = {
        "kind": kind, "half_width": [round(v, 4) for v in half], "depth": round(float(depth), 4),
        "tilt_deg": round(float(np.degrees(tilt)), 3), "approach_radius": round(float(radius), 4),
        "mouth_offset": round(float(np.linalg.norm(np.cross(mouth - TIP, HEADING))), 4), "clutter": len(items),
        "mouth": [round(float(v), 5) for v in mouth], "axis": [round(float(v), 6) for v in w],
    }
    desc = (f"Dead end: a {kind} {2 * half[0]:.2f} x {2 * half[1]:.2f} m inside and {depth:.2f} m deep, open "
            f"towards the robot (axis tilted {params['tilt_deg']:.0f} deg), {len(items)} item(s) beside the "
            f"approach.  The goal is at the back of the pocket; the robot must back out the way it came.")
    return Candidate(obstacles=pocket + items, goals=goals, via=via, structure=len(pocket), params=params,
                     description=desc, checks=dict(SPARSE_CHECKS), retract=True)
