"""Tip planners: from the goals and the tip sensors to the commanded tip path.

One concept per module:

* :mod:`navstack.planner.types`: :class:`TipCommand` and the :class:`TipPlanner` interface;
* :mod:`navstack.planner.map`: the sensed surfaces and the space seen free;
* :mod:`navstack.planner.potential`: the repulsive potential over that map;
* :mod:`navstack.planner.search`: hybrid A* descent of the potential over curvature-bounded arcs;
* :mod:`navstack.planner.steering`: following the plan at a safe speed;
* :mod:`navstack.planner.escape`: backing out along the tip's own path;
* :mod:`navstack.planner.field`: :class:`FieldPlanner`, the sensing planner (``--planner field``);
* :mod:`navstack.planner.reactive`: the reactive potential-field planner (``--planner reactive``), its baseline.

None of them reads obstacle geometry (tests/test_isolation.py).
"""

from __future__ import annotations

from navstack.planner.types import TipCommand, TipPlanner

__all__ = ["TipCommand", "TipPlanner"]
