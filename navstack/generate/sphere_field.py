"""``sphere-field``: spheres beside a bumped path, via goals on the bump (the goals mark the way).

A random goal path (2-3 via goals on a smooth bump of 0.11-0.14 m across the heading, a final goal
0.9-1.15 m ahead) and spheres (radius 0.04-0.12 m) beside it, plus spheres on the straight line
start -> final goal where the bump leaves room, so that line is blocked; more spheres, closer to the
path, with difficulty.  Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import TIP, Candidate, ball, make_guard, place, smooth_goals
from navstack.generate.checks import CheckConfig, RobotStart, path_samples
from navstack.generate.geometry import FloatArray, sphere_dict

__all__ = ["family_sphere_field"]


def family_sphere_field(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                        robot: RobotStart) -> Candidate:
    """A sphere field (module docstring) around the demo robot ``robot``."""
    n_via = int(rng.integers(2, 4))
    total = rng.uniform(0.9, 1.15)
    # a smooth bump of height amp (in a random direction across the heading) that the spheres on the
    # straight line start -> final goal force the tip through; a bump amp (1 - cos)/2 over `total` turns
    # with radius total^2 / (2 pi^2 amp) >= 0.29 m for amp <= 0.14 m
    amp = rng.uniform(0.11, 0.12 + 0.02 * difficulty)
    ang = rng.uniform(0.0, 2.0 * np.pi)
    across = np.array([0.0, np.cos(ang), np.sin(ang)])
    end_off = np.array([0.0, *rng.uniform(-0.04, 0.04, size=2)])

    def draw() -> FloatArray:
        base = np.linspace(0.0, 1.0, n_via + 2)[1:-1]
        fr = np.append(base + rng.uniform(-0.04, 0.04, size=n_via), 1.0)
        bump = amp * (1 - np.cos(2 * np.pi * fr)) / 2
        return np.array([TIP + np.array([total * f, 0.0, 0.0]) + b * across + f * f * end_off
                         for f, b in zip(fr, bump, strict=True)])

    goals = smooth_goals(draw, cfg)
    S = path_samples(robot, goals, cfg)
    guard = make_guard([S], goals, robot, cfg)
    need = robot.serpentine_radius + cfg.body_margin + 0.01
    spread = 0.03 + 0.12 * (1.0 - difficulty)
    n_near = 4 + int(round(8 * difficulty))
    near = place(rng, lambda: ball(rng, S.path, need + rng.uniform(0.0, spread), 0.3), n_near, guard)
    n_block = 1 + int(round(2 * difficulty))
    line0, line1 = TIP, goals[-1]

    def blocker() -> dict[str, Any]:
        f = rng.uniform(0.35, 0.65)
        return sphere_dict(line0 + f * (line1 - line0), rng.uniform(0.025, 0.06))

    block = place(rng, blocker, n_block, guard)
    obstacles = block + near
    params = {"via_goals": n_via, "length": round(total, 4), "amplitude": round(amp, 4),
              "spheres": len(obstacles), "blockers": len(block)}
    desc = (f"Sphere field: {len(obstacles)} spheres around a random goal path ({n_via} via goals on a "
            f"{amp:.2f} m bump, final goal {total:.2f} m ahead), {len(block)} of them on the straight line "
            f"to "
            f"the final goal.")
    return Candidate(obstacles=obstacles, goals=goals, via=goals, structure=len(obstacles), params=params,
                      description=desc)
