"""``pipe-rack``: 2-3 layers of horizontal pipes, a goal at each crossing (the goals mark the way).

2-3 layers of horizontal pipes (along y, yawed up to 10 deg, radius 0.025-0.045 m) stacked in z; each
layer leaves a free gap around the path's crossing, the crossings alternate up and down (by up to
0.3 x layer spacing^2, what a turn radius of 0.25 m allows) so the tip weaves, and the gap shrinks with
difficulty (0.25 -> 0.13 m).  Goals: at each crossing and behind the rack.  Units: metres, radians.
"""

from __future__ import annotations

import numpy as np

from navstack.generate.base import TIP, Candidate, smooth_goals
from navstack.generate.checks import CheckConfig, RobotStart
from navstack.generate.geometry import FloatArray, cylinder_dict

__all__ = ["family_pipe_rack"]


def family_pipe_rack(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                     robot: RobotStart) -> Candidate:
    """A pipe rack (module docstring); ``robot`` is unused (the rack stands ahead of the demo tip)."""
    n_layers = 3 if rng.random() < 0.3 + 0.6 * difficulty else 2
    spacing = rng.uniform(0.3, 0.35) if n_layers == 3 else rng.uniform(0.3, 0.4)
    x1 = TIP[0] + rng.uniform(0.35, 0.45)
    # alternating crossings +-amp; a turn radius >= 0.25 m allows about amp <= 0.3 spacing^2
    amp = min(0.3 * spacing**2, 0.025 + 0.03 * difficulty) * rng.uniform(0.6, 1.0)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    gap = 0.13 + 0.12 * (1.0 - difficulty) + rng.uniform(-0.01, 0.01)

    def draw() -> FloatArray:
        crossings = []
        for k in range(n_layers):
            z = TIP[2] + sign * amp * (1.0 if k % 2 == 0 else -1.0) + rng.uniform(-0.01, 0.01)
            crossings.append([x1 + k * spacing, TIP[1] + rng.uniform(-0.03, 0.03), z])
        final = [crossings[-1][0] + rng.uniform(0.12, 0.2), TIP[1] + rng.uniform(-0.03, 0.03),
                 TIP[2] + rng.uniform(-0.03, 0.03)]
        return np.array([*crossings, final])

    goals = smooth_goals(draw, cfg)
    crossings = goals[:-1]
    obstacles = []
    half_len = 0.6
    for x, y, z in crossings:
        rp = rng.uniform(0.025, 0.045)
        yaw = np.radians(rng.uniform(-10.0, 10.0))
        axis = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        levels = []
        for direction in (1.0, -1.0):
            zc = z + direction * (gap / 2 + rp)
            while abs(zc - TIP[2]) <= 0.38:
                levels.append(zc)
                zc += direction * (2 * rp + rng.uniform(0.04, 0.12))
        for zc in sorted(levels):
            c = np.array([x, y, zc])
            obstacles.append(cylinder_dict(c - half_len * axis, c + half_len * axis, rp))
    params = {"layers": n_layers, "layer_spacing": round(spacing, 4), "amplitude": round(amp, 4),
              "gap": round(gap, 4), "first_layer_x": round(x1, 4)}
    desc = (f"Pipe rack: {n_layers} layers of horizontal pipes {spacing:.2f} m apart; the free gap "
            f"({gap:.3f} m) "
            f"around the path alternates up and down by about {amp:.3f} m so the tip weaves; goals between "
            f"the pipes and behind the rack.")
    return Candidate(obstacles=obstacles, goals=goals, via=goals, structure=len(obstacles), params=params,
                      description=desc)
