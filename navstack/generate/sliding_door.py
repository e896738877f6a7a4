"""``sliding-door``: a wall with a window, shut at the start by a door that slides away later.

The capability tested is a moving obstacle (interfaces.md section 2b) that the planner must learn of through
its sensors alone: the map holds the door where the rays saw it, and must let it go once the rays see through
the window, without ever being told that anything moves.

Layout.  The way (:func:`navstack.generate.bend_clutter.bend_path`): straight from the tip, an arc of radius
0.35-0.5 m turning by up to 10 + 15 d deg towards a random direction across the heading, then straight along
the new axis ``w`` through the window's centre, 0.12-0.2 m after the arc, to the goal 0.22-0.35 m behind the
window; via points every 5 cm.  The wall: a plate 10-20 mm thick across ``w``, 0.9 m square, made of four
boxes around a square window of half width 0.1 - 0.025 d m (minus up to 1 cm, at least 0.075 m), its edges
rolled at random about ``w``.  The door: a plate 8-12 mm thick 10-20 mm behind the wall, overlapping the window
by 3 cm on every side; at ``t_open`` = 2-6 + 6 d s it slides along one of the window's edges (a random one)
at 0.04-0.08 m/s until its near edge is 8 cm past the window's edge, and stops there (``linear`` motion with
``start`` and ``stop``).  The only goal is the destination: neither the window nor the door is marked.

The checks (:func:`navstack.generate.checks.run_checks`) see every obstacle where its motion ends (the door
open); the robot's start is checked at t = 0 (door shut).  The door shuts the window at t = 0 by construction
(tests/test_generate_moving.py measures it).  The time limit is :func:`~navstack.generate.build.time_limit_for`
plus the time the door stops.

Difficulty d (0..1): narrower windows, sharper turns onto the window's axis, later doors (the robot, at the
planners' 0.06 m/s, reaches the wall at about 8-11 s: an easy door is open by then, a hard one is not).
Units: metres, radians, seconds.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import HEADING, TIP, Candidate
from navstack.generate.bend_clutter import bend_path
from navstack.generate.checks import CheckConfig, RobotStart
from navstack.generate.geometry import FloatArray, perpendicular, rounded
from navstack.generate.sparse import SPARSE_CHECKS, box_on_axes

__all__ = ["family_sliding_door", "window_wall"]

WALL_HALF = 0.45
"""Half the wall's side [m]."""
OVERLAP = 0.03
"""How far the shut door covers the wall round the window [m]."""
CLEAR = 0.08
"""How far past the window's edge the open door's near edge stops [m]."""


def window_wall(centre: FloatArray, axes: FloatArray, half: float, thickness: float) -> list[dict[str, Any]]:
    """Four boxes making a ``2 WALL_HALF`` square plate of ``thickness`` [m] across ``axes[:, 0]`` at ``centre``,
    with a square window of half width ``half`` [m] at its centre (edges along ``axes[:, 1]`` and ``[:, 2]``)."""
    _, e1, e2 = axes.T
    side = 0.5 * (WALL_HALF - half)  # half the width of the wall beside the window
    return [
        box_on_axes(centre + (half + side) * e1, axes, (thickness / 2, side, WALL_HALF)),
        box_on_axes(centre - (half + side) * e1, axes, (thickness / 2, side, WALL_HALF)),
        box_on_axes(centre + (half + side) * e2, axes, (thickness / 2, half, side)),
        box_on_axes(centre - (half + side) * e2, axes, (thickness / 2, half, side)),
    ]


def family_sliding_door(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                        robot: RobotStart) -> Candidate:
    """A wall with a window and a sliding door (module docstring) ahead of the demo robot ``robot``."""
    tilt = np.radians(rng.uniform(0.0, 10.0 + 15.0 * difficulty))
    b = perpendicular(rng, HEADING)
    radius = rng.uniform(0.35, 0.5)
    lead = rng.uniform(0.12, 0.2)  # straight along the axis before the window
    behind = rng.uniform(0.22, 0.35)  # the goal behind the window
    straight = max(0.05, rng.uniform(0.45, 0.6) - radius * tilt - lead)
    half = float(max(0.075, 0.1 - 0.025 * difficulty - rng.uniform(0.0, 0.01)))
    wall_t, door_t, gap = rng.uniform(0.01, 0.02), rng.uniform(0.008, 0.012), rng.uniform(0.01, 0.02)
    points, _, _, _ = bend_path(straight, radius, tilt, lead + behind, b)
    w = np.cos(tilt) * HEADING + np.sin(tilt) * b
    goal = points[-1]
    window = goal - behind * w
    e1 = perpendicular(rng, w)
    axes = np.column_stack([w, e1, np.cross(w, e1)])
    wall = window_wall(window, axes, half, wall_t)
    slide = axes[:, 1 + int(rng.integers(2))] * rng.choice([-1.0, 1.0])
    speed = rng.uniform(0.04, 0.08)
    t_open = rng.uniform(2.0, 6.0) + 6.0 * difficulty
    travel = 2.0 * half + OVERLAP + CLEAR  # the door's near edge from OVERLAP before the window to CLEAR past it
    door = box_on_axes(window + (wall_t / 2 + gap + door_t / 2) * w, axes,
                       (door_t / 2, half + OVERLAP, half + OVERLAP))
    t_stop = t_open + travel / speed
    door["motion"] = {"type": "linear", "velocity": rounded(speed * slide), "start": round(float(t_open), 3),
                      "stop": round(float(t_stop), 3)}
    params = {
        "window_half_width": round(half, 4), "tilt_deg": round(float(np.degrees(tilt)), 3),
        "approach_radius": round(float(radius), 4), "window": rounded(window), "axis": rounded(w),
        "window_offset": round(float(np.linalg.norm(np.cross(window - TIP, HEADING))), 4),
        "door_opens": round(float(t_open), 3), "door_open": round(float(t_stop), 3),
        "door_speed": round(float(speed), 4),
    }
    desc = (f"Sliding door: a wall with a {2 * half:.2f} m square window {np.linalg.norm(window - TIP):.2f} m "
            f"ahead (its axis tilted {params['tilt_deg']:.0f} deg), shut by a door behind it that slides away from "
            f"{t_open:.1f} s to {t_stop:.1f} s.  The goal is behind the window; neither is marked.")
    return Candidate(obstacles=[*wall, door], goals=goal[None], via=points[1:], structure=len(wall) + 1,
                     params=params, description=desc, checks=dict(SPARSE_CHECKS))
