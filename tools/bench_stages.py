"""Where a trial's time goes, stage by stage: each stage of the control loop timed inside the trial itself.

Each world's trial runs once to warm up (slither controller, field planner, seed 0), then again with a timer
around each stage below; every stage's time is printed in ms per control step, indented under the stage that
calls it (a child's time is part of its parent's).  The timers add about a microsecond per call, and the
trial's own total (``TrialResult.wall_time`` / ``steps``) is printed above them to compare.

Stages: the servo (``JointServo.step``, ``command``), the planning step (``_Simulation._plan``: the sensor's
``RaySensor.read``, the estimator's ``RangeEstimator.update``, the planner's ``FieldPlanner.step``, and
inside it the map's ``SensedMap.update``, the searches, the navigation functions and the plan-still-holds
checks), the measurement (``_Simulation._measure`` and its ``Scene.clearance``) and the controller
(``SlitherController.step``).  Then the planner's searches split by why they ran: ``improve`` (the plan
being followed still holds; a short search for another, which replaces it if it reaches the goal) and
``full`` (it does not, escapes' candidate searches included), each as reached / failed, count and seconds.
Nothing is changed: the wrapped calls return what they return.  Usage::

    python tools/bench_stages.py [--worlds W.json ...]

The default worlds are the paper demo, ``truss_clutter.json`` and slot-rack seed 5 (sparse goals).  Timing
varies with the machine's load: compare numbers of one run, and see ``tools/bench_floor.py`` for the floor.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from contextlib import ExitStack
from unittest import mock

from _bench_worlds import HELP, bench_worlds

import navstack.planner.field as field
import navstack.trial as trial
from navstack.control.controller import SlitherController
from navstack.estimate import RangeEstimator
from navstack.planner.map import SensedMap
from navstack.planner.search import REACHED
from navstack.sim.rays import RaySensor
from navstack.sim.scene import Scene
from navstack.sim.servo import JointServo
from navstack.world import World

STAGES: list[tuple[str, object, str]] = [
    ("servo.step", JointServo, "step"),
    ("servo.command", JointServo, "command"),
    ("plan (sense, estimate, plan)", trial._Simulation, "_plan"),
    ("  sensor: RaySensor.read", RaySensor, "read"),
    ("  estimator: RangeEstimator.update", RangeEstimator, "update"),
    ("  planner: FieldPlanner.step", field.FieldPlanner, "step"),
    ("    map update: SensedMap.update", SensedMap, "update"),
    ("    searches", field, "search"),
    ("    navigation functions", field, "navigation_function"),
    ("    plan still holds: still_clear", field, "still_clear"),
    ("measure (kinematics, metrics)", trial._Simulation, "_measure"),
    ("  clearance: Scene.clearance", Scene, "clearance"),
    ("controller: SlitherController.step", SlitherController, "step"),
]
"""(label, owner, attribute): the timed calls, in print order; the indent shows which stage calls which."""


def _timed(label: str, f, spent: dict[str, float]):
    def call(*args, **kwargs):
        t = time.perf_counter()
        try:
            return f(*args, **kwargs)
        finally:
            spent[label] += time.perf_counter() - t
    return call


def _search_split(stack: ExitStack, searches: dict[tuple[str, str], list[float]]) -> None:
    """Count the planner's searches by why they ran (the plan held or not) and how they ended."""
    why = ["full"]
    holds, search = field.FieldPlanner._current_plan_holds, field.search

    def current_plan_holds(self) -> bool:
        h = holds(self)
        why[0] = "improve" if h else "full"
        return h

    def counted(*args, **kwargs):
        t = time.perf_counter()
        plan = search(*args, **kwargs)
        entry = searches[(why[0], "reached" if plan.status == REACHED else "failed")]
        entry[0] += 1
        entry[1] += time.perf_counter() - t
        return plan

    stack.enter_context(mock.patch.object(field.FieldPlanner, "_current_plan_holds", current_plan_holds))
    stack.enter_context(mock.patch.object(field, "search", counted))


def run(label: str, world: World) -> None:
    """Time ``world``'s trial stage by stage and print the table."""
    trial.run_trial(world, seed=0)
    spent: dict[str, float] = defaultdict(float)
    searches: dict[tuple[str, str], list[float]] = defaultdict(lambda: [0, 0.0])
    with ExitStack() as stack:
        _search_split(stack, searches)  # first: the stage timer below wraps the counting search
        for name, owner, attr in STAGES:
            stack.enter_context(mock.patch.object(owner, attr, _timed(name, getattr(owner, attr), spent)))
        result = trial.run_trial(world, seed=0)
    n = max(result.steps, 1)
    print(f"{label}: {result.reason}, {result.steps} control steps, "
          f"{1e3 * result.wall_time / n:.3f} ms per control step in all")
    for name, _, _ in STAGES:
        print(f"  {name:44s} {1e3 * spent[name] / n:7.3f}")
    for (why, end), (count, seconds) in sorted(searches.items()):
        print(f"  searches, {why:8s}{end:8s} {count:4d} calls {seconds:7.3f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=None, help=HELP)
    args = ap.parse_args()
    worlds = bench_worlds(args.worlds)
    print("ms per control step (a stage's time includes the stages indented under it)")
    for label, world in worlds:
        run(label, world)


if __name__ == "__main__":
    main()
