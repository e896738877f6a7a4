"""Recovery when no way leads on: back out along the path, wait boxed in, look back, give up.

The part of :class:`~navstack.planner.field.FieldPlanner` that runs when its search finds no way on from the
commanded state (a base class of it; it uses the planner's map, path, follower, config and searches):

* **escape** (:func:`~navstack.planner.escape.find_branch_point`): back out along the tip's own path to the point
  with the least retreat plus plan cost, and go on from there (:meth:`Recovery._start_escape`,
  :meth:`Recovery._step_retreat`); at most ``EscapeConfig.max_retreats`` for one goal;
* **wait** (:class:`~navstack.planner.escape.Wait`): boxed in (no way from any point back along the path), hold
  still while the map forgets (what boxes the tip in may have moved), searching again as it changes, for
  ``EscapeConfig.patience``;
* **look back**: waiting, once the map has forgotten points and then gone quiet, back ``EscapeConfig.look_back``
  along the path, still forgetting, and search again (:meth:`Recovery._start_look_back`);
* **give up** (:meth:`Recovery._stall`): ``stalled``, with the reason.

Units: metres, seconds.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from navstack.path import MIN_ARC, PathMemory
from navstack.planner.escape import WAIT_ESCAPE_PERIODS, Scanned, Wait, find_branch_point
from navstack.planner.map import SensedMap
from navstack.planner.search import NO_PATH, PARTIAL, REACHED, Plan
from navstack.planner.steering import PlanFollower
from navstack.planner.types import TipCommand
from navstack.retreat import Retreat

if TYPE_CHECKING:
    from navstack.planner.field import FieldPlannerConfig

__all__ = ["Recovery"]

_log = logging.getLogger("navstack.planner.field")


class Recovery:
    """Escape, wait, look back and give up, for :class:`~navstack.planner.field.FieldPlanner` (its base class)."""

    config: FieldPlannerConfig
    goals: NDArray[np.float64]
    map: SensedMap
    path: PathMemory
    follower: PlanFollower
    time: float
    mode: str
    stalled: bool
    stall_reason: str | None
    command_goal: int
    retreat: Retreat | None
    retreats: int
    look_backs: int
    _pending: tuple[float, Plan | Wait] | None
    _budget_spent: bool  # a search of the last escape (or its fallback) spent its budget without a way on
    _wait: Wait | None
    _scanned: Scanned | None  # the stretch of path escapes searched in vain (for the same goal, path and map)
    _goal_retreats: dict[int, int]
    _deep_escape_done: tuple[int, int] | None  # (goal, its retreats) of the last deeper escape scan
    _goal_look_backs: dict[int, int]
    _last_branch: float | None
    _planned_at: float
    _planned_version: int

    if TYPE_CHECKING:  # provided by the planner
        def arm_blocks_the_way(self) -> bool: ...
        def _plan_from(self, p: NDArray[np.float64], h: NDArray[np.float64], k: int, at: float | None = None,
                       budget: int | None = None) -> Plan: ...
        def _cost_floor(self, p: NDArray[np.float64], k: int) -> float: ...
        def _replan(self) -> None: ...
        def step_hold(self, dt: float) -> TipCommand: ...

    def _stall(self, why: str) -> None:
        """Give up: ``why`` becomes :attr:`stall_reason` (and an INFO line of the ``navstack.planner.field``
        logger), with a note when only the arm behind the serpentine blocks the way."""
        self.stalled = True
        self.mode = "stalled"
        if self.arm_blocks_the_way():
            scfg = self.config.search
            why += (f"; the serpentine alone has a way on, but a search of "
                    f"{max(scfg.max_expansions, self.config.deep_budget)} expansions found none that keeps the arm, "
                    f"carried after it in its start posture, SearchConfig.arm_margin = {scfg.arm_margin:g} m from "
                    "every sensed surface")
        self.stall_reason = f"goals[{self.command_goal}] (of {len(self.goals)}): {why}"
        _log.info("stalled at %s", self.stall_reason)

    def _start_escape(self, fallback: Plan | None = None) -> None:
        n = self._goal_retreats.get(self.command_goal, 0)
        if n >= self.config.escape.max_retreats:
            # every way tried for this goal has closed: give up rather than wander
            self._stall(f"no way on after {n} escapes back along the path (EscapeConfig.max_retreats)")
            return
        # a new escape soon after the last branch point must go back beyond it (no retreat cycles)
        limit = self.path.end_arc_length
        if self._last_branch is not None and limit - self._last_branch < 0.3:
            limit = self._last_branch - self.config.escape.step
        spent: list[bool] = []
        searched: list[float] = []
        scanned = self._scanned_before()

        def plan_at(p: NDArray[np.float64], h: NDArray[np.float64], at: float) -> Plan:
            plan = self._plan_from(p, h, self.command_goal, at)
            spent.append(plan.status == PARTIAL)
            searched.append(at)
            return plan

        def cost_floor(p: NDArray[np.float64]) -> float:
            return self._cost_floor(p, self.command_goal)

        found = find_branch_point(self.path, plan_at, self.config.escape, before=limit, cost_floor=cost_floor,
                                  skip=None if scanned is None else scanned.covers)
        if found is None:  # a candidate's search may only have spent its budget
            partial = {s for s, sp in zip(searched, spent, strict=True) if sp}
            earlier = scanned if scanned is not None and scanned.spent else None  # (skipped: searched before)
            found = self._deep_branch_point(
                limit, lambda s: s in partial or (earlier is not None and earlier.covers(s)), cost_floor)
        self._budget_spent = (any(spent) or (scanned is not None and scanned.spent)
                              or (fallback is not None and fallback.status == PARTIAL))
        self._scanned = None
        if found is None:
            if scanned is None:
                scanned = Scanned(self.command_goal, self.map.version, self.retreats + self.look_backs,
                                  math.inf, -math.inf, False)
            scanned.extend(searched, any(spent))
            self._scanned = scanned
            if fallback is not None:
                self.follower = PlanFollower(fallback, self.config.steering, self.follower.v)
            elif self.config.escape.patience > 0:
                # boxed in: hold still while the map may still change; what boxes the tip in may have moved (or
                # still move) without the map having seen it often enough to sense it: the map forgets while it
                # waits (a static map again once a way on is found: the map's "Forgetting")
                self._wait = Wait.begin(self.time, self.map.forgotten)  # (what goes as forgetting begins counts)
                if self.map.config.detect_motion:
                    self.map.begin_forgetting()
                self.mode = "wait"
            else:
                self._stall(self._boxed_in())
            return
        self.retreats += 1
        self._goal_retreats[self.command_goal] = n + 1
        s, plan = found
        self._last_branch = s
        self._pending = (s, plan)
        self.retreat = Retreat(self.path, s, self.config.escape.speed, self.config.escape.accel)
        self.mode = "retreat"

    def _deep_branch_point(self, limit: float, spent: Callable[[float], bool],
                           cost_floor: Callable[[NDArray[np.float64]], float]) -> tuple[float, Plan] | None:
        """An escape's scan found no branch point, but the searches at some candidates (the arc lengths [m] where
        ``spent``) only spent their budget: those candidates searched once more with
        ``FieldPlannerConfig.deep_budget`` expansions (:func:`find_branch_point` as before, the other candidates
        skipped), once per goal and escape count (the planner's retreats for that goal) from
        ``FieldPlannerConfig.deep_escape_after_retreats`` escapes on, before following the
        partial plan from the tip ("explore"), or waiting boxed in.  A way on from back along the path that a
        deeper search finds is taken rather than a partial plan onwards.  Without it, on
        ``worlds/hard6/corner_late.json`` (all 3 seeds) the partial plans led the tip on into the pocket in
        front of a wall's end, where it could no longer turn round the end; every escape's searches spent
        their budget at every candidate (the way round from 0.1-0.35 m back took 11-19 thousand expansions, the
        budget being 8000), and once boxed in it waited and stalled, never backing out.  None if that finds
        none (or it is not due, or there is no deeper budget)."""
        cfg = self.config
        key = (self.command_goal, self._goal_retreats.get(self.command_goal, 0))
        if cfg.deep_budget <= cfg.search.max_expansions or key == self._deep_escape_done \
                or key[1] < cfg.deep_escape_after_retreats:
            return None
        tried: list[float] = []

        def deep(p: NDArray[np.float64], h: NDArray[np.float64], at: float) -> Plan:
            tried.append(at)
            return self._plan_from(p, h, self.command_goal, at, budget=cfg.deep_budget)

        found = find_branch_point(self.path, deep, cfg.escape, before=limit, cost_floor=cost_floor,
                                  skip=lambda s: not spent(s))
        if tried:
            self._deep_escape_done = key
        return found

    def _scanned_before(self) -> Scanned | None:
        """The stretch of path earlier escapes searched in vain, if it still counts (:class:`Scanned`)."""
        scanned = self._scanned
        if scanned is None or not scanned.holds(self.command_goal, self.map.version, self.retreats + self.look_backs):
            return None
        return scanned

    def _boxed_in(self) -> str:
        """Why no way on was found (the last escape's searches): boxed in, or a search spent its budget."""
        back = f"nor from any point up to {self.config.escape.max_back:g} m back along the path"
        if self._budget_spent:
            return (f"no way on found from here, {back}, within a search's budget (SearchConfig.max_expansions = "
                    f"{self.config.search.max_expansions}; a way may exist that is longer or more winding)")
        return f"no way on from here (boxed in), {back}"

    def _step_wait(self) -> TipCommand:
        """Boxed in: hold the command; search again as :meth:`Wait.next_search` says (from the command, or an
        escape back along the path too); give up after ``EscapeConfig.patience`` still boxed in."""
        cfg = self.config
        wait = self._wait
        assert wait is not None
        if self._may_look_back(wait):
            self._start_look_back(wait)
            return self.step_hold(0.0)
        what = wait.next_search(self.time, self.map.forgetting, self.map.forgotten, self._planned_at, cfg.nav_period)
        if what == "escape":
            self._wait = None
            if not self._replan_waiting(wait):
                return self.step_hold(0.0)
        elif what == "here":
            p, h = self.follower.state()
            plan = self._plan_from(p, h, self.command_goal)
            self._planned_at, self._planned_version = self.time, self.map.version
            if plan.status != NO_PATH:  # a way on, or one to explore (the budget spent), as an escape's
                self._wait = None
                self.map.end_forgetting()
                self.follower = PlanFollower(plan, cfg.steering, 0.0)
                self.mode = "plan" if plan.status == REACHED else "explore"
                return self.step_hold(0.0)
        if self.time - wait.since >= cfg.escape.patience:
            self._stall(f"{self._boxed_in()}; no way either after waiting {cfg.escape.patience:g} s "
                        f"(EscapeConfig.patience) for the map to change")
        return self.step_hold(0.0)

    def _may_look_back(self, wait: Wait) -> bool:
        """Whether to back out to look again (``EscapeConfig.look_back``): the map has forgotten points since the
        wait began and none for :data:`~navstack.planner.escape.WAIT_ESCAPE_PERIODS` ``nav_period``, this goal
        has look-backs left, there is path to back along, and patience left."""
        esc = self.config.escape
        quiet = wait.quiet_after_change(self.time, self.map.forgotten, WAIT_ESCAPE_PERIODS * self.config.nav_period)
        return (quiet and self._goal_look_backs.get(self.command_goal, 0) < esc.max_look_backs
                and self.path.end_arc_length - self._look_back_to() > 0.02 and self.time - wait.since < esc.patience)

    def _look_back_to(self) -> float:
        return max(self.path.end_arc_length - self.config.escape.look_back, self.path.start_arc_length, MIN_ARC + 1e-6)

    def _start_look_back(self, wait: Wait) -> None:
        """Back ``EscapeConfig.look_back`` along the path, the map still forgetting, to search again from there:
        a door that opened while the tip waited turned away from it, off its axis, is seen by a ray or two only,
        and the stale points of it the tip cannot see past stay in the map (three ``sliding-door`` trials that
        stalled at seed 2026)."""
        n = self._goal_look_backs.get(self.command_goal, 0)
        self._goal_look_backs[self.command_goal] = n + 1
        self.look_backs += 1
        self._pending = (self._look_back_to(), wait)  # the wait goes on after it, unless a way is found
        self._wait = None
        self.retreat = Retreat(self.path, self._pending[0], self.config.escape.speed, self.config.escape.accel)
        self.mode = "retreat"

    def _look_again(self, wait: Wait) -> None:
        """A look-back done: plan from where it ended (a way on, an escape, or the same wait going on).  If the
        map forgot nothing while the tip backed out, the wait is still quiet and the next look-back (if the goal
        has one left) follows at once, from farther back."""
        p, t = self.path.point_at(self.path.end_arc_length)
        here = Plan.standing(p, t, self.command_goal)
        self.follower = PlanFollower(here, self.config.steering, 0.0)
        self._replan_waiting(wait)

    def _replan_waiting(self, wait: Wait) -> bool:
        """Search again for a wait (:meth:`_replan`): a way on, or an escape back along the path, ends it (the
        map static again until motion is sensed, unless the planner gave up); boxed in again, ``wait`` goes on.
        Returns whether it goes on."""
        self._replan()
        if self._wait is None:
            if not self.stalled:
                self.map.end_forgetting()
            return False
        self._wait.go_on_from(wait)
        return True

    def _step_retreat(self, dt: float) -> TipCommand:
        """Back along the path (an escape, or a look-back); at its end, the escape's plan, or a look again."""
        r = self.retreat
        assert r is not None
        cmd = r.step(dt)
        if r.done:
            s, plan = self._pending  # type: ignore[misc]
            self.path.truncate(s)
            self.retreat = None
            self._pending = None
            if isinstance(plan, Wait):  # a look-back
                self._look_again(plan)
                return cmd
            self.follower = PlanFollower(plan, self.config.steering, 0.0)
            self._planned_version = -1  # the map has grown while backing out: replan now
            self._planned_at = -math.inf
        return cmd
