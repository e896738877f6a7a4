"""``rod-forest``: a forest of thin parallel rods with a winding way through; goals before and after it.

The way: straight ahead from the tip for 0.2-0.3 m to the entry goal, then one smooth lobe
``A (1 - cos(2 pi f)) / 2`` (f = 0..1 over 0.7-0.8 m) across the heading, then 0.12-0.18 m straight to the
destination.  The lobe's direction ``n`` is random about the heading, and the rods (cylinders of radius
``r``, 0.6-1 m long) all run along ``a``, across both the heading and ``n``: seen along them, the tip
slaloms in a plane through a forest.  The rods stand in a slab from the entry goal to 0.1 m before the
destination, up to 0.3 m to either side of the line, with their surfaces at least the user's clearance from
every link along the way (:func:`~navstack.generate.base.place` with the family's guard); one to three of
them stand on the straight line from the entry goal to the destination where the lobe leaves room, so the
spline through the goals alone collides.  The rest are drawn at random in the slab (a draw the guard
refuses is drawn again, up to 25 times): they fill what the way leaves free, so between the rods there are
gaps of every width, most of them too narrow for the tip or too tight a turn for the body.

Goals: only the entry goal and the destination.

Difficulty d (0..1): rod radius U(6, 12) -> U(4, 8) mm; 20 -> 60 rods drawn besides the blockers (a draw
fails only if 25 in a row crowd the way; none did in 90 worlds); lobe height U(0.09, 0.1) -> U(0.1, 0.11) m,
at most lobe^2 / (2 pi^2 0.3 m) (a turn radius of 0.3 m: 0.083-0.108 m).  Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import HEADING, TIP, Candidate, make_guard, place
from navstack.generate.checks import CheckConfig, RobotStart, path_samples
from navstack.generate.geometry import FloatArray, cylinder_dict
from navstack.generate.sparse import BLOCKED_DEPTH, SPARSE_CHECKS, cross_axes, sparse_config

__all__ = ["family_rod_forest", "lobe_path"]

HALF_WIDTH = 0.3
"""How far [m] across the line (along ``n``) the forest reaches on either side."""


def lobe_path(straight: float, lobe: float, height: float, after: float, n: FloatArray,
              step: float = 0.04) -> FloatArray:
    """Samples (every ``step`` [m] along the heading) of the way: ``straight`` along the heading from the tip,
    a lobe ``height (1 - cos(2 pi f)) / 2`` along the unit ``n`` over ``lobe`` [m], then ``after`` straight."""
    total = straight + lobe + after
    x = np.append(np.arange(0.0, total, step), total)
    f = np.clip((x - straight) / lobe, 0.0, 1.0)
    y = height * (1.0 - np.cos(2.0 * np.pi * f)) / 2.0
    return TIP + x[:, None] * HEADING + y[:, None] * n


def family_rod_forest(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                      robot: RobotStart) -> Candidate:
    """A rod forest (module docstring) ahead of the demo robot ``robot``."""
    cfg = sparse_config(cfg)
    roll = float(rng.uniform(0.0, np.pi))
    a, n = cross_axes(HEADING, roll)
    if rng.random() < 0.5:
        n = -n
    straight, lobe, after = rng.uniform(0.2, 0.3), rng.uniform(0.7, 0.8), rng.uniform(0.12, 0.18)
    # the lobe turns with radius lobe^2 / (2 pi^2 height) >= 0.3 m: the spline through its samples turns a
    # little tighter, and the checks demand 0.25 m
    height = min(rng.uniform(0.09 + 0.01 * difficulty, 0.1 + 0.01 * difficulty), lobe**2 / (2 * np.pi**2 * 0.3))
    via = lobe_path(straight, lobe, height, after, n)
    via = via[np.linalg.norm(via - TIP, axis=1) > 0.05]
    entry = TIP + straight * HEADING
    final = TIP + (straight + lobe + after) * HEADING
    goals = np.array([entry, final])
    S = path_samples(robot, via, cfg)
    guard = make_guard([S], goals, robot, cfg)
    r_lo, r_hi = 0.006 - 0.002 * difficulty, 0.012 - 0.004 * difficulty
    x_lo, x_hi = straight, straight + lobe + after - 0.1

    def rod(x: float, y: float) -> dict[str, Any]:
        c = TIP + x * HEADING + y * n + rng.uniform(-0.1, 0.1) * a
        half = rng.uniform(0.3, 0.5)
        return cylinder_dict(c - half * a, c + half * a, float(rng.uniform(r_lo, r_hi)))

    def blocker() -> dict[str, Any]:  # on the line, under the lobe's high part
        return rod(straight + lobe * rng.uniform(0.35, 0.65), float(rng.uniform(-0.01, 0.01)))

    def tree() -> dict[str, Any]:
        return rod(float(rng.uniform(x_lo, x_hi)), float(rng.uniform(-HALF_WIDTH, HALF_WIDTH)))

    block = place(rng, blocker, 1 + int(rng.integers(0, 3)), guard)
    trees = place(rng, tree, 20 + int(round(40 * difficulty)), guard)
    rods = block + trees
    params = {"roll_deg": round(float(np.degrees(roll)), 3), "lobe_height": round(float(height), 4),
              "lobe_length": round(float(lobe), 4), "entry_standoff": round(float(straight), 4),
              "rods": len(rods), "blockers": len(block), "rod_radius": [round(r_lo, 4), round(r_hi, 4)],
              "lobe_direction": [round(float(v), 6) for v in n]}
    desc = (f"Rod forest: {len(rods)} parallel rods ({1000 * r_lo:.0f}-{1000 * r_hi:.0f} mm radius) across the "
            f"approach, {len(block)} of them on the straight line; a way through winds {height:.2f} m to "
            f"one side over {lobe:.2f} m.  Goals: an entry point in front of the forest and the destination behind "
            f"it, nothing in between.")
    return Candidate(obstacles=rods, goals=goals, via=via, structure=len(rods), params=params, description=desc,
                     checks=dict(SPARSE_CHECKS), blocked_depth=BLOCKED_DEPTH)
