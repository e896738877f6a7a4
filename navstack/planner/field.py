"""The sensing tip planner (``--planner field``): map, potential, search, steering, escape.

The paper's planner treats the tip as a mobile robot in a potential field built from proximity
sensing.  Here the field is descended along paths the tip can actually follow:

1. **sense -> map** (:mod:`navstack.planner.map`): every filtered reading adds its hits as surface
   points and marks the space its rays crossed as seen free; the tip's own position is free;
2. **potential** (:mod:`navstack.planner.potential`): the remaining length to the goals plus
   Khatib's repulsion from the sensed points, with unseen space next to a sensed surface costly;
3. **search** (:mod:`navstack.planner.search`): a hybrid A* over curvature-bounded arcs from the
   commanded state through every remaining goal: the path of least potential that the tip can
   follow; **replanned** when a new surface point comes near the path ahead, when the goal index
   moves, and every ``replan_period`` while the map changes; a full replan that finds no path keeping
   ``Repulsion.margin`` tries once more with ``tight_margin`` (a passage too narrow for the margin; after an
   escape for the goal also one whose search spent its budget);
4. **steering** (:mod:`navstack.planner.steering`): the command runs along the plan, slowing near
   surfaces, stopping at the plan's end;
5. **escape** (:mod:`navstack.planner.escape`, run by :mod:`navstack.planner.recovery`): when no path leads
   on, back out along the tip's own path (reverse commands) to the point from which one does with the least
   retreat plus plan cost, and go on from there; boxed in, wait for the map to change, and look back;
6. **seen openings** (:mod:`navstack.planner.opening`): when the last reading's rays went far through a gap
   ringed by sensed points towards the goal, a replan also searches through that gap, and keeps that plan
   unless it costs more than ``OpeningConfig.cost_ratio`` times the other (a way round the unseen outside of a
   structure looks free, and the tip commits to it before the walls appear).

It never reads obstacle geometry: its inputs are the start, the goals, the robot's own tip state
and the filtered sensor readings (tests/test_isolation.py).  Units: metres, seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.estimate import RangeEstimate
from navstack.path import PathMemory
from navstack.planner.escape import EscapeConfig, Scanned, Wait
from navstack.planner.map import MapConfig, SensedMap
from navstack.planner.opening import OpeningConfig, far_rays, find_opening
from navstack.planner.own_arm import OwnArmConfig, turns_into_arm
from navstack.planner.potential import NavigationFunction, Repulsion, navigation_function
from navstack.planner.proximity import sets_closer_than
from navstack.planner.recovery import Recovery
from navstack.planner.search import (
    NO_PATH,
    PARTIAL,
    REACHED,
    ArmShape,
    Plan,
    SearchConfig,
    navigation_region,
    only_the_arm_blocks,
    search,
    still_clear,
)
from navstack.planner.steering import PlanFollower, SteeringConfig
from navstack.planner.types import TipCommand
from navstack.retreat import Retreat
from navstack.validate import instance, integer, non_negative, positive

RELAXED_GOAL_FRACTION = 0.85
"""The goal ball (fraction of each tolerance) of a full search's second try when the first, at the search's own
``goal_fraction``, reaches no plan: a goal at the edge of the turning limit (15.6 mm from any path of radius
0.25 m, tolerance 20 mm) is then passed within its tolerance instead of stalling the planner."""

__all__ = ["FieldPlanner", "FieldPlannerConfig"]


@dataclass(frozen=True)
class FieldPlannerConfig:
    """Parameters of :class:`FieldPlanner` (each part has its own dataclass).

    Attributes:
        replan_period: replan at least this often while the map changes [s].
        horizon: how far ahead [m] new points are checked against the plan.
        ray_start: rays mark free space from this distance from the tip [m].
        urgent_margin: a new surface point within the blocking radius plus this of the plan ahead
            forces a replan at once [m].
        improve_budget: expansions of a replan while the plan being followed still holds.
        deep_budget: expansions of one more search when a full replan spent the search's own budget without
            reaching every goal, once ``deep_after_retreats`` escapes for the same goal have not found a way
            (0 or below the search's budget: never).
        deep_after_retreats: escapes (backing out) for the current goal before a spent budget earns the deeper
            search (a rack's slot can need it; most failed searches are settled by the first escapes, and a
            deeper search that fails costs 2.5 times the budget); then once per escape.
        deep_escape_after_retreats: escapes for the current goal before an escape whose scan found no branch point
            searches its budget-spent candidates once more with ``deep_budget`` (:mod:`~navstack.planner.recovery`;
            then once per escape).  Not before the first: early on, with little of the map seen, a deeper search
            finds ways through space nobody has looked at, and backing out to take one cost a sliding-door trial
            the door's opening (`sliding-door` d0.5 #6 of the README's validation set, seed 8181: reached ->
            stalled with the deeper scan at once).
        path_spacing: vertex spacing of the record of the commanded path: the controller's [m].
        nav_period: the navigation function is recomputed at least this often while the map
            changes [s] (and whenever the next goal changes, or a search fails with the old one).
        tight_margin: when a full replan from the command finds that no plan keeps ``Repulsion.margin`` from
            sensed surfaces (``NO_PATH``; or its budget is spent once an escape has been made for the goal),
            one more search keeps this margin instead [m]: a
            passage narrower than twice ``body_radius + margin`` (a 7 cm slot for the 5 cm body).  The plan found is
            followed while it keeps this margin, and replaced once a replan finds one that keeps
            ``Repulsion.margin``.  5 mm, not less: the range noise is 4 mm (1 sigma), and with 3 mm a review
            world's 2 mm plate seen edge-on (its edge never sensed) was hit.  None, or not below
            ``Repulsion.margin``: no such search (the planner backs out or stalls instead).
        own_arm: how near a plan may carry the serpentine to the robot's own arm (a plan that turns back into it
            is refused: :mod:`navstack.planner.own_arm`).
    """

    map: MapConfig = field(default_factory=MapConfig)
    repulsion: Repulsion = field(default_factory=Repulsion)
    search: SearchConfig = field(default_factory=SearchConfig)
    steering: SteeringConfig = field(default_factory=SteeringConfig)
    escape: EscapeConfig = field(default_factory=EscapeConfig)
    opening: OpeningConfig = field(default_factory=OpeningConfig)
    own_arm: OwnArmConfig = field(default_factory=OwnArmConfig)
    replan_period: float = 0.5
    horizon: float = 0.6
    ray_start: float = 0.03
    urgent_margin: float = 0.005
    nav_period: float = 1.0
    path_spacing: float = 1e-3
    improve_budget: int = 1500
    deep_budget: int = 20000
    deep_after_retreats: int = 2
    deep_escape_after_retreats: int = 1
    tight_margin: float | None = 0.005

    @property
    def least_margin(self) -> float:
        """The least clearance [m] a plan keeps from sensed surfaces: ``tight_margin`` when it is below
        ``Repulsion.margin`` (the search that lets a passage narrower than the margin through), else that margin."""
        margin = self.repulsion.margin
        return margin if self.tight_margin is None else min(self.tight_margin, margin)

    def __post_init__(self) -> None:
        for name, cls in (("map", MapConfig), ("repulsion", Repulsion), ("search", SearchConfig),
                          ("steering", SteeringConfig), ("escape", EscapeConfig), ("opening", OpeningConfig),
                          ("own_arm", OwnArmConfig)):
            instance(self, name, cls)
        positive(self, "replan_period", "horizon", "ray_start", "urgent_margin", "nav_period", "path_spacing")
        non_negative(self, "tight_margin", none_ok=True)
        integer(self, "improve_budget", lo=1)
        integer(self, "deep_budget", "deep_after_retreats", "deep_escape_after_retreats", lo=0)


def _vec3(v: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be 3 numbers, got {type(v).__name__}") from exc
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be 3 finite numbers, got {v!r}")
    return a.copy()


def _fuse(smap: SensedMap, reading: RangeEstimate | None,
          ray_start: float) -> tuple[NDArray[np.float64], NDArray[np.bool_]] | None:
    """sense -> map: one filtered reading's rays into ``smap``, free from ``ray_start`` [m] (measured rays hit
    at their filtered range; a ray without a measurement is free up to the maximum range where the filter is
    not coasting).  A :attr:`~navstack.estimate.RangeEstimate.lagging` ray tells the map nothing this time:
    its estimate may lie in front of a rim it ran past, and its measurement, more than 2 stds from the
    estimate, is as likely the noisiest of the reading (a noise std of 4 mm: 4.6 % of measured rays are).
    Returns the rays' ranges as fused [m] and which rays told the map something (None without a reading)."""
    if reading is None:
        return None
    if not isinstance(reading, RangeEstimate):
        raise TypeError(f"reading must be a RangeEstimate (a filtered tip-sensor reading) or None, "
                        f"got {type(reading).__name__}")
    measured = np.asarray(reading.measured, dtype=np.bool_)
    if reading.lagging is not None:
        measured = measured & ~np.asarray(reading.lagging, dtype=np.bool_)
    valid = np.asarray(getattr(reading, "valid", np.ones_like(measured)), dtype=np.bool_)
    tracking = np.asarray(reading.tracking, dtype=np.bool_)
    max_range = float(getattr(reading, "max_range", 0.4))
    ranges = np.where(measured, reading.ranges, max_range)
    informative = measured | (valid & ~tracking)
    smap.update(reading.origins, reading.directions, np.full(len(ranges), ray_start), ranges, measured, informative)
    return ranges, informative


def _passes(plan: Plan, point: NDArray[np.float64], within: float) -> bool:
    """Whether ``plan``'s samples come within ``within`` [m] of ``point``."""
    return bool(np.min(np.sum((plan.points - point) ** 2, axis=1)) <= within * within)


def _without_via(via: Plan, k: int, goals: NDArray[np.float64]) -> Plan:
    """A plan searched through a via point and then ``goals[k:]`` as a plan for ``goals`` from ``k`` on: its goal
    indices shifted back (the via point counts as goal ``k`` not yet passed), and no stop on the via point."""
    index = k + np.maximum(via.goal_index - 1, 0)
    if len(via.stops):
        at = np.array([via.state(s)[0] for s in via.stops])
        on_goal = np.min(np.linalg.norm(at[:, None, :] - goals[None, k:, :], axis=2), axis=1) < 1e-6
        stops = via.stops[on_goal]
    else:
        stops = via.stops
    return replace(via, goal_index=index.astype(np.int64), stops=stops)


def _out_of_reach(p: NDArray[np.float64], heading: NDArray[np.float64], goal: NDArray[np.float64],
                  radius: float) -> bool:
    """Whether ``goal`` lies behind the plane through ``p`` normal to ``heading``, or within the circle of
    ``radius`` [m] on which the tip at ``p`` would turn towards it (in the plane of ``heading`` and ``goal - p``):
    moving forward with curvature at most ``1 / radius``, the tip would first have to turn away or round."""
    n = float(np.linalg.norm(heading))
    if n < 1e-12:
        return False
    r = goal - p
    along = float(np.dot(r, heading)) / n
    lateral = float(np.sqrt(max(float(np.dot(r, r)) - along * along, 0.0)))
    return along < 0.0 or along * along + (lateral - radius) ** 2 < radius * radius


class FieldPlanner(Recovery):
    """Sensor-based tip planner (see the module docstring).

    Args:
        start: (3,) initial tip position [m] (world).
        heading: (3,) initial tip direction (world).
        goals: (k, 3) goals [m], in order.
        tolerances: (k,) goal tolerances [m].
        config: parameters (``None`` = defaults).
        arm: the robot's own arm at the start (its capsules' axis, the flange, the radius), so paths that
            would carry it into a sensed surface are not planned; ``None``: only the flange is checked.
    """

    def __init__(self, start: ArrayLike, heading: ArrayLike, goals: ArrayLike, tolerances: ArrayLike,
                 config: FieldPlannerConfig | None = None, arm: ArmShape | None = None) -> None:
        if config is not None and not isinstance(config, FieldPlannerConfig):
            raise TypeError(f"config must be a FieldPlannerConfig, got {type(config).__name__}")
        if arm is not None and not isinstance(arm, ArmShape):
            raise TypeError(f"arm must be an ArmShape or None, got {type(arm).__name__}")
        self.arm = arm
        self.config = cfg = config or FieldPlannerConfig()
        self.start = _vec3(start, "start")
        h = _vec3(heading, "heading")
        if np.linalg.norm(h) < 1e-9:
            raise ValueError("heading must be non-zero")
        self.goals = np.asarray(goals, dtype=np.float64).reshape(-1, 3)
        self.tolerances = np.asarray(tolerances, dtype=np.float64).reshape(-1)
        if len(self.goals) == 0 or len(self.tolerances) != len(self.goals) or not np.isfinite(self.goals).all():
            raise ValueError("goals must be (k >= 1, 3) finite positions with k tolerances")
        box = np.vstack([self.start, self.goals])
        self.map = SensedMap(box.min(axis=0), box.max(axis=0), cfg.map)
        unit = h / np.linalg.norm(h)
        backbone = self.start - np.outer(np.arange(7), unit) * cfg.search.link_length
        self.path = PathMemory(backbone, link_length=cfg.search.link_length, spacing=cfg.path_spacing)
        self.time = 0.0
        self._nav: tuple[int, int, NavigationFunction, float] | None = None
        self.command_goal = 0
        """Goals the command itself has passed (within the search's reach of them), in order."""
        self._goal_retreats: dict[int, int] = {}
        self._deep_done: tuple[int, int] | None = None  # (goal, its escapes) of the last deeper search
        self._deep_escape_done: tuple[int, int] | None = None  # (goal, its escapes) of the last deeper escape scan
        self.tight_plans = 0  # plans found only with FieldPlannerConfig.tight_margin
        self._rays: tuple | None = None  # the last reading's rays as fused (origins, directions, ranges, informative)
        self.opening_plans = 0  # plans kept through a seen opening
        self.arm_refusals = 0  # plans refused: they would carry the serpentine into the arm (_clear_of_arm)
        self.turn_back_plans = 0  # plans up to a goal after which the tour turns back (_to_turn_back)
        self.follower = PlanFollower(self._plan_from(self.start, h / np.linalg.norm(h), 0), cfg.steering)
        self.goal_index = 0
        self.mode = "plan"
        self.stalled = False
        self.stall_reason: str | None = None
        """Why the planner gave up (None while it has not)."""
        self.retreat: Retreat | None = None
        self._pending: tuple[float, Plan | Wait] | None = None  # (branch point, its plan; or a look-back's wait)
        self._planned_at = 0.0
        self._planned_version = -1
        self.replans = 0
        self.retreats = 0
        self._command_goal_s = 0.0
        self._last_branch: float | None = None
        self._wait: Wait | None = None  # boxed in, waiting for the map to change
        self._scanned: Scanned | None = None  # the stretch of path escapes searched in vain
        self._budget_spent = False  # the last escape's searches spent their budget (not boxed in: the stall reason)
        self._goal_look_backs: dict[int, int] = {}
        self.look_backs = 0

    # ---- planning
    def _navigation(self, p: NDArray[np.float64], k: int, fresh: bool) -> NavigationFunction | None:
        """The navigation function to goal ``k``, cached for ``nav_period`` while it still covers ``p``."""
        if k >= len(self.goals):
            return None
        cfg = self.config
        cached = self._nav
        stale = (cached is None or cached[0] != k or fresh or not np.isfinite(cached[2].lookup(p))
                 or (self.map.version != cached[1] and self.time - cached[3] >= cfg.nav_period))
        if stale:
            lo, hi = navigation_region(p, self.goals[k], cfg.search)
            reach = cfg.search.goal_fraction * float(self.tolerances[k])
            nav = navigation_function(self.map, self.goals[k], reach, lo, hi, cfg.repulsion)
            self._nav = cached = (k, self.map.version, nav, self.time)
        return cached[2]

    def _plan_from(self, p: NDArray[np.float64], h: NDArray[np.float64], k: int, at: float | None = None,
                   budget: int | None = None) -> Plan:
        """Search from the state (p, h) for goals from ``k`` on, the body lying along the commanded path
        behind arc length ``at`` (default: its end), with at most ``budget`` expansions (default: the
        search's own)."""
        cfg = self.config
        scfg = cfg.search if budget is None else replace(cfg.search, max_expansions=budget)
        k = self._passed(p, k)
        end = self.path.end_arc_length if at is None else at
        history = self._history(end, 7.5 * cfg.search.link_length)

        def attempt(config: SearchConfig, fresh: bool = False, repulsion: Repulsion = cfg.repulsion) -> Plan:
            return self._clear_of_arm(search(self.map, p, h, self.goals, self.tolerances, k, config, repulsion,
                                             history=history, nav=self._navigation(p, k, fresh), arm=self.arm),
                                      history)

        plan = attempt(scfg)
        if plan.status != REACHED and self._nav is not None and self._nav[1] != self.map.version:
            plan = attempt(scfg, fresh=True)  # the map has grown
        if at is None and (budget is None or plan.status == REACHED):
            # (an improvement that found nothing changes nothing: the plan being followed still holds)
            plan = self._prefer_opening(p, h, k, plan, scfg, history)
        if plan.status == REACHED or budget is not None:
            return plan
        if at is not None:  # (the tries below are for a full replan from where the robot is, not a branch point's:
            # each of an escape's up to 15 would search again, 2.5 s per escape on a baffle world)
            return self._to_turn_back(p, h, k, scfg, history) or plan
        if scfg.goal_fraction < RELAXED_GOAL_FRACTION:
            # a goal at the edge of what the turning limit allows may be passed within its tolerance but
            # not within the search's smaller ball: one more try with the larger one
            relaxed = attempt(replace(scfg, goal_fraction=RELAXED_GOAL_FRACTION))
            if relaxed.status == REACHED:
                return relaxed
        escapes = (self.command_goal, self._goal_retreats.get(self.command_goal, 0))
        if plan.status == PARTIAL and cfg.deep_budget > scfg.max_expansions \
                and escapes[1] >= cfg.deep_after_retreats and escapes != self._deep_done:
            # the budget ran out (not a dead end: that is NO_PATH) again after escapes for this goal: a plan
            # between rows of a rack can need more expansions than the budget most searches finish well
            # within; one deeper search (once per escape) before backing the robot out of a way that exists
            self._deep_done = escapes
            deep = attempt(replace(scfg, max_expansions=cfg.deep_budget))
            if deep.status == REACHED:
                return deep
        spent_after_escape = plan.status == PARTIAL and escapes[1] >= 1
        if (plan.status == NO_PATH or spent_after_escape) \
                and cfg.tight_margin is not None and cfg.tight_margin < cfg.repulsion.margin:
            # no way with the margin, or none found within the budget once an escape for this goal has shown
            # that the way with the margin does not go on (before any escape, a tight plan after a spent budget
            # slips into rack slots it backs out of)
            tight = attempt(scfg, repulsion=replace(cfg.repulsion, margin=cfg.tight_margin))
            if tight.status == REACHED:
                self.tight_plans += 1
                return tight
        return self._to_turn_back(p, h, k, scfg, history) or plan

    def _to_turn_back(self, p: NDArray[np.float64], h: NDArray[np.float64], k: int, config: SearchConfig,
                      history: NDArray[np.float64]) -> Plan | None:
        """When no plan reaches every goal from ``k`` on: a plan through the goals from ``k`` up to the first goal
        ``j`` after which the tour turns back or sharper than the turning limit (goal ``j + 1`` lies behind goal
        ``j`` or within its turning circle, for the heading from the goal before ``j``, or from ``p``), if goal
        ``j + 1`` is out of forward reach where that plan ends (:func:`_out_of_reach`).  The tip moves forward only:
        the whole tour would need a loop round, through the robot's own body when the next goal lies on the way in.
        Once at goal ``j`` the planner finds no way on forward and backs along its own path (an escape) to where
        the next goals are reached, or planned to forward.  None otherwise."""
        g = self.goals
        radius = config.min_turn_radius
        prev, j = p, None
        for i in range(k, len(g) - 1):
            if _out_of_reach(g[i], g[i] - prev, g[i + 1], radius):
                j = i
                break
            prev = g[i]
        if j is None:
            return None
        plan = self._clear_of_arm(search(self.map, p, h, g[: j + 1], self.tolerances[: j + 1], k, config,
                                         self.config.repulsion, history=history, nav=self._navigation(p, k, False),
                                         arm=self.arm), history)
        if plan.status != REACHED or not _out_of_reach(plan.points[-1], plan.tangents[-1], g[j + 1], radius):
            return None
        self.turn_back_plans += 1
        return plan

    def _prefer_opening(self, p: NDArray[np.float64], h: NDArray[np.float64], k: int, plan: Plan,
                        config: SearchConfig, history: NDArray[np.float64]) -> Plan:
        """``plan`` (from the state (p, h) for goals from ``k`` on), or a plan through the nearest seen opening
        towards goal ``k`` (:func:`~navstack.planner.opening.find_opening`) if that one reaches every goal and
        costs at most ``OpeningConfig.cost_ratio`` times ``plan`` (any cost if ``plan`` does not reach them).
        Not when ``plan`` already passes through the opening, nor once the planner has backed out more than
        ``OpeningConfig.max_escapes`` times for this goal (nor, in :meth:`_plan_from`, after an improvement that
        reached no plan: the plan being followed holds).  Beside a plan that reaches every goal, the search
        through the opening has ``OpeningConfig.budget`` expansions."""
        ocfg = self.config.opening
        if (not ocfg.enabled or k >= len(self.goals)
                or self._goal_retreats.get(self.command_goal, 0) > ocfg.max_escapes):
            return plan
        far = None if self._rays is None else far_rays(*self._rays, ocfg.far_range)  # only when replanning
        centre = find_opening(self.map.surface_points, far, p, self.goals[k], ocfg, heading=h,
                              min_turn_radius=config.min_turn_radius)
        if centre is None or (plan.status == REACHED and _passes(plan, centre, ocfg.min_clearance)):
            return plan  # no opening, or the plan goes through it already (no sensed point is this near its centre)
        goals = np.vstack([centre, self.goals[k:]])
        tolerances = np.concatenate([[ocfg.via_tolerance], self.tolerances[k:]])
        if plan.status == REACHED:  # only a preference: a small budget
            config = replace(config, max_expansions=min(config.max_expansions, ocfg.budget))
        via = self._clear_of_arm(search(self.map, p, h, goals, tolerances, 0, config, self.config.repulsion,
                                        history=history, arm=self.arm), history)
        if via.status != REACHED or (plan.status == REACHED and via.cost > ocfg.cost_ratio * plan.cost):
            return plan
        self.opening_plans += 1
        return _without_via(via, k, self.goals)

    def _clear_of_arm(self, plan: Plan, history: NDArray[np.float64]) -> Plan:
        """``plan``, or none (``NO_PATH``) if following it would carry the serpentine into the robot's own arm
        (:func:`~navstack.planner.own_arm.turns_into_arm`: a loop round to a goal behind the one before it)."""
        if plan.status == NO_PATH or self.arm is None or not turns_into_arm(
                history, plan.points, self.arm, self.config.search.link_length, self.config.repulsion.body_radius,
                self.config.own_arm):
            return plan
        self.arm_refusals += 1
        return Plan.standing(plan.points[0], plan.tangents[0], int(plan.goal_index[0]), cost=float("inf"),
                             expansions=plan.expansions, repulsion=plan.repulsion)

    def _history(self, end: float, length: float, spacing: float = 0.02) -> NDArray[np.float64]:
        """The commanded path's ``length`` [m] up to arc length ``end``, every ``spacing`` [m], oldest first."""
        s = np.append(np.arange(max(end - length, 0.0), end - 0.5 * spacing, spacing), end)
        return self.path.points_at(s)

    def _cost_floor(self, p: NDArray[np.float64], k: int) -> float:
        """A lower bound [m] of the cost of any plan from ``p`` through the goals from ``k`` on: a plan's cost is
        at least its length, which passes within each goal's tolerance of it, in order."""
        k = self._passed(p, k)
        if k >= len(self.goals):
            return 0.0
        g, tol = self.goals[k:], self.tolerances[k:]
        legs = np.linalg.norm(np.diff(np.vstack([p, g]), axis=0), axis=1)
        slack = tol + np.concatenate([[0.0], tol[:-1]])  # the first leg starts at p itself
        return float(np.maximum(legs - slack, 0.0).sum())

    def _passed(self, p: NDArray[np.float64], k: int) -> int:
        """Goals from ``k`` on that the command ``p`` is within reach of (already there)."""
        reach = self.config.search.goal_fraction * self.tolerances
        while k < len(self.goals) and float(np.linalg.norm(p - self.goals[k])) <= reach[k]:
            k += 1
        return k

    def _sync_goals(self, goal_index: int) -> bool:
        """Reconcile the trial's goal count with the command's; True if the plan must change.

        The command passes a goal a step or two before the tip (it lags by a millimetre or two), so
        the plan goes by the command's count; if the trial counts a goal the command has not passed,
        or the command passed one that the tip then missed (0.1 m on, still not counted), the
        command's count takes the trial's and the planner replans for the right goal.
        """
        self.goal_index = int(goal_index)
        if self.goal_index > self.command_goal or (
                self.command_goal > self.goal_index and self.path.end_arc_length - self._command_goal_s >= 0.1):
            self.command_goal = self.goal_index
            return True
        return False

    def _replan(self) -> None:
        """Plan again from the commanded state.  While the plan being followed still holds, a short search
        looks for a better one and keeps the old plan if it finds none; otherwise a full search."""
        p, h = self.follower.state()
        holds = self._current_plan_holds()
        plan = self._plan_from(p, h, self.command_goal,
                               budget=self.config.improve_budget if holds else None)
        self.replans += 1
        self._planned_at = self.time
        self._planned_version = self.map.version
        if plan.status != REACHED:
            if holds:
                return  # a search that fails where the plan being followed still holds changes nothing
            # no way on found from here (boxed in, or the budget spent in a maze): back out to where
            # one exists; with none, explore along the partial plan rather than give up
            self._start_escape(fallback=plan if plan.status != NO_PATH else None)
            return
        self.follower = PlanFollower(plan, self.config.steering, self.follower.v)

    def _current_plan_holds(self) -> bool:
        """The plan being followed goes through every goal and is still clear in the map as it is now."""
        f = self.follower
        if f.plan.status != REACHED or f.remaining <= 0.0:
            return False
        cfg = self.config
        history = self._history(self.path.end_arc_length, 7.5 * cfg.search.link_length)
        return still_clear(self.map, f.plan, f.s, history, cfg.search, cfg.repulsion, self.arm)

    def arm_blocks_the_way(self) -> bool:
        """Whether only the arm blocks the way on from the commanded state (:func:`~navstack.planner.search.
        only_the_arm_blocks`, the arm's search with ``deep_budget``).  False without an arm."""
        if self.arm is None:
            return False
        p, h = self.follower.state()
        history = self._history(self.path.end_arc_length, 7.5 * self.config.search.link_length)
        k = self._passed(p, self.command_goal)
        return only_the_arm_blocks(self.map, p, h, self.goals, self.tolerances, k, self.config.search,
                                   self.config.repulsion, history, self._navigation(p, k, False), self.arm,
                                   self.config.deep_budget)

    def _needs_replan(self) -> bool:
        cfg = self.config
        f = self.follower
        plan = f.plan
        if plan.status != REACHED and self.time - self._planned_at >= cfg.replan_period:
            return True
        if plan.status == REACHED and f.remaining <= 0.0 and self.command_goal < len(self.goals):
            return True  # at the end of a plan up to where the tour turns back (_to_turn_back)
        new = self.map.new_points
        if len(new):  # a new point near the plan ahead (every fourth sample over the horizon)
            i, j = np.searchsorted(plan.arc, (f.s, f.s + cfg.horizon))
            if sets_closer_than(new, plan.points[i : j + 1 : 4], cfg.repulsion.r_block + cfg.urgent_margin):
                return True
        return self.map.version != self._planned_version and self.time - self._planned_at >= cfg.replan_period

    # ---- step
    def step(self, dt: float, tip: ArrayLike, direction: ArrayLike, reading, goal_index: int) -> TipCommand:
        """Advance by ``dt`` [s]; ``tip`` the measured tip [m], ``goal_index`` the goals reached so far."""
        tip = _vec3(tip, "tip")
        _vec3(direction, "direction")  # checked, not used: the planner steers its own commanded heading
        self.time += dt
        fused = _fuse(self.map, reading, self.config.ray_start)
        if fused is not None and self.config.opening.enabled:
            self._rays = (reading.origins, reading.directions, *fused)
        self.map.mark_free(tip, self.config.repulsion.body_radius)
        changed = self._sync_goals(goal_index)
        if self.stalled:
            return TipCommand(self.path.head, np.zeros(3), True, "stalled")
        if self.retreat is not None:
            return self._step_retreat(dt)
        if self._wait is not None:
            return self._step_wait()
        if changed or self._needs_replan():
            self._replan()
            if self.retreat is not None or self.stalled or self._wait is not None:
                return self.step_hold(dt)
        x_d, _ = self.follower.state()
        body = self.config.repulsion.body_radius
        clearance = self.map.distance(x_d, r=self.config.steering.slow_clearance + body) - body
        lag = float(np.linalg.norm(x_d - tip))
        p, v = self.follower.advance(dt, clearance, lag)
        self.path.record(p)
        k = self._passed(p, self.command_goal)
        if k != self.command_goal:
            self.command_goal = k
            self._command_goal_s = self.path.end_arc_length
        self.mode = "plan" if self.follower.plan.status == REACHED else "explore"
        return TipCommand(p, v, False, self.mode)

    def step_hold(self, dt: float) -> TipCommand:
        """Hold the command where it is (the step on which an escape starts or the planner gives up)."""
        return TipCommand(self.path.head, np.zeros(3), self.stalled, self.mode)

