"""The reactive tip planner (``--planner reactive``): a 3D potential field on the serpentine's tip.

The paper (section 2) finds the tip path "by treating the robot tip as a mobile robot" with a sensor-based
method such as the potential field, and lets the body slither after it.  This planner turns sensor readings
into the commanded tip trajectory ``x_d(t), xdot_d(t)`` that the slithering controller follows, one step at a
time and without a map beyond the points it has seen; it is kept as the baseline of the sensing planner
(:mod:`navstack.planner.field`).  **It never reads obstacle geometry**: its only inputs are the sensor
readings, the current goal and the robot's own state (tests/test_isolation.py).

Common interface: ``step(dt, tip_position_measured, tip_direction, reading, goal, goal_tolerance, *,
approach=False, next_goal=None) -> TipCommand``.  The caller owns the goal list and advances to the next goal
when the *actual* tip comes within ``goal_tolerance`` (:class:`GoalListAdapter` gives the trial loop's
goal-index interface); ``reading`` is a raw :class:`~navstack.sensing.SensorReading` (the planner filters it)
or a :class:`~navstack.estimate.RangeEstimate` already filtered by the caller.

One part per module:

* :mod:`~navstack.planner.reactive.config`: :class:`PlannerConfig`;
* :mod:`~navstack.planner.reactive.memory`: :class:`PointMemory`, the points seen, one per voxel;
* :mod:`~navstack.planner.reactive.terms`: repulsion, the turning limit's geometry, the aim, the speed;
* :mod:`~navstack.planner.reactive.lookahead`: the sideways push from the tube ahead;
* :mod:`~navstack.planner.reactive.gap`: centring on the opening ahead;
* :mod:`~navstack.planner.reactive.guide_pursuit`: pure pursuit of the goal spline;
* :mod:`~navstack.planner.reactive.wall_follow`: the escape from a local minimum;
* :mod:`~navstack.planner.reactive.planner`: :class:`PotentialFieldPlanner`, one step of it all.
"""

from __future__ import annotations

from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.memory import PointMemory
from navstack.planner.reactive.planner import GoalListAdapter, PotentialFieldPlanner
from navstack.planner.types import TipCommand, TipPlanner

__all__ = ["GoalListAdapter", "PlannerConfig", "PointMemory", "PotentialFieldPlanner", "TipCommand", "TipPlanner"]
