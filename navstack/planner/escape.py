"""Backing out: when no path leads on from where the tip is, retreat along the tip's own path.

A wrong turn into a pocket costs serpentine length for good unless the robot backs out: the
slithering body can only go where the tip has been, and the tip can only turn while it moves.
So when the search finds no way on from the commanded state (every reachable state expanded, or its
budget spent), the planner looks *behind* it on its own commanded path for a point from which a way on
exists: candidates every ``step`` [m] back along the path (the state there is the path's point and
forward tangent), nearest first, up to the start of the path.  Of those whose search leads through every goal,
the **branch point** is the one with the least retreat plus plan cost (both in metres: the whole way
from where the tip is, backing out counted at its length); the scan stops once the retreat alone is no
less than the best total so far (a plan's cost is never negative), and a candidate whose retreat plus a
lower bound of its plan's cost (``cost_floor``) cannot beat that total is not searched, nor is one in a stretch
of path an earlier scan searched in vain in the same map (:class:`Scanned`).  Taking the
nearest such point instead sent the tip, in the ``rod-forest`` worlds, back down the side it had just
failed on (the way round a forest's edge through unseen space) while the way on the other side,
0.1-0.3 m farther back, cost 0.2-0.5 m less in all: 4 of 20 trials timed out at seed 5353, 1 with
this rule.  The command then runs back along the path to it
(reverse commands, :class:`navstack.retreat.Retreat`: the slithering controller drops the retracted
part of its path memory, every joint point staying on the path), the path record is cut there, and
the tip goes forward again on the new plan.  If no candidate has a way on, or the goal has cost
``max_retreats`` retreats already, the planner follows a fallback plan if it has one, else waits for the
map to change (``patience``, :class:`Wait`; once the map has forgotten points and gone quiet, it looks back,
``look_back``) and then gives up (``stalled``).  :mod:`navstack.planner.recovery` runs all of this.

The planner's record of its commanded tip path is a :class:`navstack.path.PathMemory` with the
controller's vertex spacing: it records the same commands as the controller's, so a point at arc
length ``s`` on it is on the controller's path too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from numpy.typing import NDArray

from navstack.path import PathMemory
from navstack.planner.search import REACHED, Plan
from navstack.validate import integer, non_negative, positive

__all__ = ["TIE", "WAIT_ESCAPE_PERIODS", "EscapeConfig", "Scanned", "Wait", "find_branch_point"]

TIE = 1e-9
"""Totals (retreat plus plan cost) within this [m] of each other are equal: the nearer branch point is kept."""

WAIT_ESCAPE_PERIODS = 4
"""Waiting boxed in, an escape (up to 15 searches back along the path) is tried again at most every this many
``nav_period`` [s]; from the command, every ``nav_period`` (the map forgetting).  Measured on a static world that
boxes the tip in (the adversarial zigzag duct, ``navstack run`` seed 0): 4.9 s of wall time without waiting, 14.2 s
waiting with an escape each time the map forgot points, 7.6 s with this throttle.  Also how long [``nav_period``]
the map must have forgotten nothing before a look-back (``EscapeConfig.look_back``)."""


@dataclass(frozen=True)
class EscapeConfig:
    """Parameters of the retreat (metres, seconds).

    Attributes:
        step: spacing of the candidate branch points along the path [m].
        min_back: the first candidate lies this far behind the tip [m].
        max_back: no candidate farther back than this [m].
        speed: retreat speed [m/s].
        accel: retreat acceleration [m/s^2].
        max_retreats: retreats allowed for one goal; one more and the planner gives up (``stalled``).
        patience: boxed in (no way on from the command, nor from any branch point), the planner holds still and
            searches again from where it is each time the map has changed (at most once a second) for this
            long [s] before it gives up: an obstacle may move away (a door that opens later); 0: at once.
        look_back: waiting, once the map has forgotten points since the wait began (what boxed the tip in may
            have moved) and then none for :data:`WAIT_ESCAPE_PERIODS` ``nav_period``, the tip backs this far [m]
            along its own path, the map still forgetting, and searches again from there (:class:`Wait`).
        max_look_backs: look-backs allowed for one goal.
    """

    step: float = 0.1
    min_back: float = 0.05
    max_back: float = 1.5
    speed: float = 0.05
    accel: float = 0.1
    max_retreats: int = 6
    patience: float = 20.0
    look_back: float = 0.15
    max_look_backs: int = 2

    def __post_init__(self) -> None:
        positive(self, "step", "min_back", "max_back", "speed", "accel", "look_back")
        non_negative(self, "patience")
        integer(self, "max_retreats", "max_look_backs", lo=0)


def find_branch_point(path: PathMemory, plan_from: Callable[[NDArray, NDArray, float], Plan],
                      config: EscapeConfig, before: float | None = None,
                      cost_floor: Callable[[NDArray], float] | None = None,
                      skip: Callable[[float], bool] | None = None) -> tuple[float, Plan] | None:
    """The arc length behind the end of ``path`` (and at or before ``before``), but not behind the tip's
    start, from which ``plan_from`` finds a complete way on (a plan through every goal) with the least
    retreat (from the end of ``path``) plus plan cost [m]; of totals within :data:`TIE`, the nearer one.

    ``plan_from(position, heading, s)`` searches from the path's state at arc length ``s`` and returns its
    :class:`Plan`; this returns ``(s, plan)`` or None.  ``cost_floor(position)``, if given, is a lower bound
    of the cost of any plan from ``position`` [m] (the search's costs are never less than the path's length):
    a candidate whose retreat plus that bound cannot beat the best total so far is not searched.  The choice
    among the candidates searched is the same; but a search not made no longer refreshes what ``plan_from``
    may cache (the planner's navigation function), so a later search may differ in rare cases (none did on
    the 140 validation trials of docs/speed.md, twenty-third round).  A candidate at an arc length for which
    ``skip(s)`` is true is not searched either (:class:`Scanned`: an earlier scan found no way on from there).
    """
    first = path.start_arc_length
    end = path.end_arc_length if before is None else min(path.end_arc_length, before + config.min_back)
    back = config.min_back
    best: tuple[float, Plan] | None = None
    best_total = math.inf
    while back <= config.max_back + 1e-9:
        s = max(end - back, first)
        retreat = path.end_arc_length - s
        if retreat >= best_total:
            break  # no plan from farther back makes up for the longer retreat (a plan's cost is >= 0)
        p, t = path.point_at(s)
        if (cost_floor is not None and retreat + cost_floor(p) >= best_total - TIE) or (skip is not None and skip(s)):
            plan = None  # could not beat the best total, or searched in vain before: not searched
        else:
            plan = plan_from(p, t, s)
        if plan is not None and plan.status == REACHED and retreat + plan.cost < best_total - TIE:
            best, best_total = (s, plan), retreat + plan.cost
        if s <= first:
            break
        back += config.step
    return best


@dataclass
class Scanned:
    """The stretch of the path behind the tip that escapes searched in vain (no candidate had a way on) in the map
    as it is now.

    Following a partial plan ("explore": the search's budget spent), the planner searches for a branch point
    again at every replan, every ``replan_period``.  Its candidates lie every ``step`` back from the path's end,
    which has moved on a few centimetres since.  While the map has not changed (its ``version``: no point added,
    moved or forgotten), most of them ask again what the last scan asked at nearly the same point of the same path
    in the same map; so the candidates within the stretch searched before are not searched again
    (:func:`find_branch_point`'s ``skip``), only the new path beyond it, as long as the goal is the same and the
    path behind has not been cut (no retreat or look-back since).  Once the map has changed, every candidate is
    searched again: a candidate whose search spent its budget may find a way in a map grown by a few points (a
    scan skipping it in a grown map lost a branch point on ``worlds/hard5/far_slot.json``).  Measured on
    ``worlds/hard5/goal_far.json`` (only the arm blocks the way; every search spends its budget): docs/speed.md,
    thirty-fifth round.

    Attributes:
        goal: the goal the scans were for.
        version: the map's version then.
        cuts: the planner's retreats plus look-backs then (each cuts the path).
        lo, hi: the least and greatest arc length searched [m].
        spent: a search of the scans spent its budget (rather than finding every way closed).
    """

    goal: int
    version: int
    cuts: int
    lo: float
    hi: float
    spent: bool

    def holds(self, goal: int, version: int, cuts: int) -> bool:
        """Whether the scans still count: the same goal, the same map, the path not cut since."""
        return (goal, version, cuts) == (self.goal, self.version, self.cuts)

    def covers(self, s: float) -> bool:
        """Whether arc length ``s`` [m] lies in the stretch searched."""
        return self.lo - TIE <= s <= self.hi + TIE

    def extend(self, searched: list[float], spent: bool) -> None:
        """Add a scan's searched arc lengths [m] (the new stretch next to the old one)."""
        if searched:
            self.lo, self.hi = min(self.lo, *searched), max(self.hi, *searched)
        self.spent = self.spent or spent


@dataclass
class Wait:
    """Boxed in, the planner holds still and waits (``EscapeConfig.patience``) for its map to change.

    Attributes:
        since: when the wait began [s].
        forgotten: the map's count of forgotten points at the last search.
        escaped: when an escape (the searches back along the path) was last tried [s].
        escape_forgotten: the map's count of forgotten points at the last escape (or as the wait began).
        first: the map's count of forgotten points as the wait began.
        seen: the count last seen by :meth:`quiet_after_change`.
        changed_at: when the count last changed [s] (or the wait began).
    """

    since: float
    forgotten: int
    escaped: float
    escape_forgotten: int
    first: int
    seen: int
    changed_at: float

    @classmethod
    def begin(cls, now: float, forgotten: int) -> Wait:
        """A wait beginning at time ``now`` [s], the map having forgotten ``forgotten`` points so far."""
        return cls(now, forgotten, now, forgotten, forgotten, forgotten, now)

    def go_on_from(self, earlier: Wait) -> None:
        """This wait (begun after a search back along the path, or a look-back, found no way) is ``earlier``
        going on: the patience counts from its start, and what the map forgot from its own."""
        self.since, self.first = earlier.since, earlier.first
        self.seen, self.changed_at = earlier.seen, earlier.changed_at

    def quiet_after_change(self, now: float, forgotten: int, quiet: float) -> bool:
        """Whether the map has forgotten points since the wait began (``forgotten``, the count now) and none
        for the last ``quiet`` [s] (time ``now`` [s]): what boxed the tip in may have moved, and what the tip
        sees from where it is has stopped changing the map."""
        if forgotten != self.seen:
            self.seen, self.changed_at = forgotten, now
        return forgotten != self.first and now - self.changed_at >= quiet

    def next_search(self, now: float, forgetting: bool, forgotten: int, planned_at: float,
                    nav_period: float) -> str | None:
        """What to search at time ``now`` [s]: ``"escape"`` (from the command, then back along the path),
        ``"here"`` (from the command only) or None.  Only while the map forgets, at most every ``nav_period``
        after the last plan (``planned_at``) [s]: an escape at most every :data:`WAIT_ESCAPE_PERIODS` periods,
        once the map has forgotten points since the last escape (even if none since the last search: a door
        that opens while the tip waits is forgotten within a second or two, and the escape that can take the
        way through it may only be due seconds later); else a search from here once it has forgotten points
        since the last search.  (``forgotten`` only grows.)"""
        if not forgetting or now - planned_at < nav_period:
            return None
        if now - self.escaped >= WAIT_ESCAPE_PERIODS * nav_period and forgotten != self.escape_forgotten:
            self.escaped, self.forgotten, self.escape_forgotten = now, forgotten, forgotten
            return "escape"
        if forgotten == self.forgotten:
            return None
        self.forgotten = forgotten
        return "here"
