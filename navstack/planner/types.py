"""What every tip planner shares: the command it returns and the interface the trial calls."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

__all__ = ["TipCommand", "TipPlanner"]


@dataclass(frozen=True)
class TipCommand:
    """What a tip planner commands for the next control step.

    Attributes:
        position: (3,) commanded tip position x_d [m] (world).
        velocity: (3,) commanded tip velocity xdot_d [m/s] (world).
        stalled: True when the planner has given up (the trial should end, reason ``stalled``).
        mode: diagnostic label of the planner's state (e.g. ``goal``, ``follow``, ``hold``).
        reverse: True when the command runs *back* along the tip's recorded path (a retreat): the
            slithering controller then drops the retracted part of its path memory instead of
            recording the command as new path.
    """

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    stalled: bool
    mode: str = ""
    reverse: bool = False


@runtime_checkable
class TipPlanner(Protocol):
    """Interface of the tip planners, as the trial calls them.

    A planner is built from the start, the heading, the goals and their tolerances
    (:class:`navstack.registry.PlannerContext`), never from obstacle geometry.
    """

    def step(
        self,
        dt: float,
        tip: NDArray[np.float64],
        direction: NDArray[np.float64],
        reading: object | None,
        goal_index: int,
    ) -> TipCommand:
        """Advance by ``dt`` [s] and return the tip command for the end of the period.

        ``tip`` (3,) and ``direction`` (3,) are the measured tip position [m] and unit direction
        (world); ``reading`` the filtered tip-sensor reading of this step
        (:class:`navstack.estimate.RangeEstimate`) or ``None`` for a planner that does not sense;
        ``goal_index`` how many goals the trial has seen reached (the next goal's index).
        """
        ...
