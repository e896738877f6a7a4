"""Parameters of the reactive potential-field planner (:class:`PlannerConfig`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from navstack.estimate import EstimatorConfig
from navstack.validate import flag, in_range, instance, integer, non_negative, positive

__all__ = ["PlannerConfig"]


@dataclass(frozen=True)
class PlannerConfig:
    """Parameters of :class:`PotentialFieldPlanner` (metres, seconds, radians).

    Attributes:
        v_max: cruise speed of the commanded tip [m/s].
        v_min: lowest speed while moving near obstacles [m/s] (turning needs motion).
        min_turn_radius: smallest radius of curvature of the tip path [m].
        body_radius: radius of the tip; clearances are measured from its surface [m].
        influence_distance: clearance below which an obstacle point repels [m].
        repulsion_gain: repulsion magnitude at clearance ``safety_distance``, relative
            to the unit attraction.
        safety_distance: clearance at which the speed has fallen to ``v_min`` [m].
        slow_distance: clearance below which the speed starts to fall [m].
        lookahead: length of the forward tube checked for obstacles [m].
        tube_margin: forward tube radius beyond ``body_radius`` [m].
        avoid_gain: magnitude of the sideways look-ahead push for a point at the tip.
        stop_distance: free length ahead below which the tip stops [m].
        max_lead: the commanded point waits when it leads the actual tip by this much [m].
        approach_distance: in approach mode the speed is ``v_max * d / approach_distance`` [m].
        gap_centering: steer to the estimated free-space centre of the opening ahead.
        gap_search_radius: largest lateral correction considered [m].
        gap_clearance_cap: clearance regarded as enough in an opening [m].
        gap_offset_cost: clearance traded per metre of lateral offset (tie-break to the goal line).
        gap_behind: points this far behind the tip still count for the opening [m].
        gap_min_clearance: an opening is centred on only if its best line has this clearance [m].
        gap_min_lookahead: shortest pure-pursuit distance to the opening line [m].
        gap_time_constant: low-pass time constant of the lateral correction [s].
        gap_recover_distance: the correction grows from none for an opening at the goal to
            full when the goal lies this far beyond the opening (the tip must still reach
            the goal itself) [m].
        gap_max_angle: no correction while the heading is more than this off the goal
            direction [rad].
        goal_repulsion_radius: the repulsion fades out linearly within this distance of
            the goal (a goal is a waypoint in free space; Ge & Cui's fix for goals near
            obstacles) [m].
        corner_lead: with a ``next_goal``, the carrot's parameter on the local Hermite curve
            to the goal (0 < corner_lead <= 1; larger = smoother, slower to converge).
        corner_tangent: length of the curve's tangent at the goal, in units of the distance
            to the goal (larger = the tip lines up with the corner's bisector earlier).
        guide_lookahead: with a guide (the goal spline), the carrot is this far ahead of the
            nearest guide point along the guide [m] (pure pursuit).
        guide_capture: the tip counts as on the guide within this distance of it [m]; then the
            guide's feasible curvature is trusted (no turning-circle or reachability override).
        goal_guard: fraction of the largest deflection from the goal direction that still
            lets the tip turn onto the goal (``sin a <= d / 2R``), in (0, 1].
        stall_window: time without progress that declares a stall [s].
        stall_progress: improvement of the distance to the goal that counts as progress [m].
        escape_timeout: longest boundary-following escape before giving up [s].
        max_escapes: escapes allowed per goal before giving up.
        follow_distance: clearance held while boundary following [m].
        follow_range: clearance within which points define the followed boundary [m].
        memory_voxel: cell size of the obstacle point memory [m].
        memory_radius: only memory points this close to x_d are used [m].
        memory_capacity: most points kept (the farthest are dropped beyond it).
        memory_average: samples in each voxel's running mean (noise averaging).
        estimator: the per-ray range filter parameters.
    """

    v_max: float = 0.06
    v_min: float = 0.02
    min_turn_radius: float = 0.25
    body_radius: float = 0.025
    influence_distance: float = 0.08
    repulsion_gain: float = 1.5
    safety_distance: float = 0.03
    slow_distance: float = 0.1
    lookahead: float = 0.4
    tube_margin: float = 0.035
    avoid_gain: float = 3.0
    stop_distance: float = 0.01
    max_lead: float = 0.03
    approach_distance: float = 0.1
    gap_centering: bool = True
    gap_search_radius: float = 0.12
    gap_clearance_cap: float = 0.12
    gap_offset_cost: float = 0.1
    gap_behind: float = 0.05
    gap_min_clearance: float = 0.03
    gap_min_lookahead: float = 0.12
    gap_time_constant: float = 0.3
    gap_recover_distance: float = 0.25
    gap_max_angle: float = 0.8
    goal_repulsion_radius: float = 0.05
    goal_guard: float = 0.8
    guide_lookahead: float = 0.05
    guide_capture: float = 0.05
    corner_lead: float = 0.2
    corner_tangent: float = 1.5
    stall_window: float = 10.0
    stall_progress: float = 0.03
    escape_timeout: float = 60.0
    max_escapes: int = 3
    follow_distance: float = 0.08
    follow_range: float = 0.2
    memory_voxel: float = 0.02
    memory_radius: float = 0.8
    memory_capacity: int = 50000
    memory_average: int = 10
    estimator: EstimatorConfig = field(default_factory=EstimatorConfig)

    def __post_init__(self) -> None:
        positive(self, "v_max", "min_turn_radius", "influence_distance", "safety_distance", "slow_distance",
                 "lookahead", "max_lead", "approach_distance", "gap_clearance_cap", "gap_min_lookahead",
                 "gap_recover_distance", "goal_repulsion_radius", "gap_max_angle", "guide_lookahead",
                 "guide_capture", "stall_window", "stall_progress", "escape_timeout", "follow_distance",
                 "follow_range", "memory_voxel", "memory_radius")
        non_negative(self, "v_min", "body_radius", "corner_lead", "corner_tangent", "repulsion_gain", "tube_margin",
                     "avoid_gain", "stop_distance", "gap_search_radius", "gap_offset_cost", "gap_behind",
                     "gap_min_clearance", "gap_time_constant")
        in_range(self, "goal_guard", lo=0.0, hi=1.0, lo_open=True)
        integer(self, "max_escapes", lo=0)
        integer(self, "memory_capacity", "memory_average", lo=1)
        flag(self, "gap_centering")
        instance(self, "estimator", EstimatorConfig)
        if self.v_min > self.v_max:
            raise ValueError(f"PlannerConfig.v_min ({self.v_min}) must not exceed v_max ({self.v_max})")
        if self.safety_distance >= self.slow_distance:
            raise ValueError(
                f"PlannerConfig.safety_distance ({self.safety_distance}) must be < slow_distance "
                f"({self.slow_distance})"
            )
        if self.safety_distance >= self.influence_distance:
            raise ValueError(
                f"PlannerConfig.safety_distance ({self.safety_distance}) must be < influence_distance "
                f"({self.influence_distance})"
            )

