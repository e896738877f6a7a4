"""``sized-slot-rack``: the slot rack (:mod:`~navstack.generate.slot_rack`) for a robot of its own size.

Every world draws the serpentine's capsule radius r uniformly from :data:`RADII` (12-45 mm; the default
robot is 25 mm) and writes it into ``robot.serpentine_radius``; the arm keeps 0.06 m.  The rack is drawn
for that body: slots 2 (r - 0.025) m wider than the slot rack's, so the same room on each side of the body,
and every check (the reference path's margin, the slithering body's 12 mm, the goals' path cutting into a
row, the start in PyBullet) uses r.  So the family asks whether the planners, the sensor and the
contact checks take the body's size from the world rather than from the default, on worlds that hand the
planner nothing but the entry and the destination.  Difficulty: as ``slot-rack``'s.  r is drawn first from the
sub-seed, so one seed gives the same r at every difficulty unless a later sub-seed is the one that passes the
checks (then r is drawn anew with the layout).  Units: metres.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from navstack.generate.base import Candidate
from navstack.generate.checks import CheckConfig, RobotStart
from navstack.generate.slot_rack import family_slot_rack

__all__ = ["RADII", "family_sized_slot_rack"]

RADII = (0.012, 0.045)
"""The range [m] of the serpentine radius drawn for each world."""


def family_sized_slot_rack(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                           robot: RobotStart) -> Candidate:
    """A slot rack for the demo robot ``robot`` with a serpentine radius drawn from :data:`RADII` (module
    docstring)."""
    radius = round(float(rng.uniform(*RADII)), 4)
    cand = family_slot_rack(rng, difficulty, cfg, replace(robot, serpentine_radius=radius))
    cand.serpentine_radius = radius
    cand.params["serpentine_radius"] = radius
    cand.description = cand.description.replace("Slot rack:", f"Slot rack for a serpentine of radius {radius:.4f} m:")
    return cand
