"""The contacts a moving obstacle could make between two control steps: :class:`MoverSweeps`, a base class of
:class:`~navstack.sim.scene.Scene`.

:meth:`Scene.update <navstack.sim.scene.Scene.update>` places the movers once per control step, so the
clearance queries see them only there; :meth:`MoverSweeps.swept_clearance` places each mover near the robot at
times between two steps and asks the exact distance at each (:mod:`navstack.sim.exact_distance`), refined where
the mover's speed bound leaves room for a contact (:mod:`navstack.sim.lipschitz`).  Only the simulator knows the
motion.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from navstack.sim.exact_distance import MARGIN
from navstack.sim.lipschitz import sampled_minimum
from navstack.world import LinearMotion, Motion

if TYPE_CHECKING:
    from navstack.sim.scene import Capsules, _Mover

__all__ = ["SWEEP_MAX_EXTRA", "SWEEP_RESOLUTION", "SWEEP_STEP", "MoverSweeps"]

SWEEP_STEP = 1e-3
"""The most (m) a moving obstacle moves between two of :meth:`Scene.swept_clearance`'s even samples; where a
contact could hide between two (the mover's speed bound, :mod:`navstack.sim.lipschitz`), more are taken."""

SWEEP_MAX_EXTRA = 5000
"""The most samples :meth:`Scene.swept_clearance` adds between its even ones, per mover and control step; past
them it counts a contact wherever one could still hide (a mover sliding past a link within micrometres for a
whole step: a possible wrong failure, never a missed contact)."""

SWEEP_RESOLUTION = 1e-6
"""m: :meth:`Scene.swept_clearance` stops halving an interval over which the mover moves at most this; a contact
shallower than half of it may hide there."""


class MoverSweeps:
    """:meth:`swept_clearance` for :class:`~navstack.sim.scene.Scene`, which holds the fields declared here."""

    if TYPE_CHECKING:  # the scene's own fields and methods, declared for type checkers only
        client: Any
        movers: tuple[_Mover, ...]
        _file_boxes: tuple[NDArray[np.float64], NDArray[np.float64]] | None
        _capsules: dict[int, list[tuple[int, np.ndarray, np.ndarray, float]]]

        def _place_exact(self, index: int, shift: NDArray[np.float64]) -> None: ...

        def _exact_distances(self, capsules: Capsules, bodies: Sequence[int],
                             within: float) -> list[tuple[int, float]]: ...

    def swept_clearance(self, robot_id: int, t0: float, t1: float, below: float,
                        robot_boxes: tuple[NDArray[np.float64], NDArray[np.float64]],
                        robot_capsules: Capsules | None = None, previous_capsules: Capsules | None = None) -> float:
        """The smallest distance (m) from ``robot_id`` to the moving obstacles while they move from simulated
        time ``t0`` to ``t1`` (s); ``below`` if none comes closer than that.

        :meth:`update` places the movers once per control step, so :meth:`clearance` sees them only there:
        at 0.5 m/s and 30 Hz a mover moves 17 mm between two looks, enough to graze a link and leave unseen.
        Here each mover is placed at times from ``t0`` to ``t1`` no more than :data:`SWEEP_STEP` of the relative
        motion apart, the distance asked at each, and then between two of them wherever the speed bound leaves
        room for a contact there (:mod:`navstack.sim.lipschitz`: a mover that reverses between samples, a
        vibration, hid a contact of up to half the spacing); a contact shallower than :data:`SWEEP_RESOLUTION`
        / 2 may still hide.  Every distance is exact (:mod:`navstack.sim.exact_distance`: movers are
        primitives, the robot's links capsules).  The mover is put back where :meth:`update` placed it at
        ``t1``.

        ``robot_capsules``: the robot's capsules now, at ``t1`` (read from PyBullet if None);
        ``previous_capsules``: at ``t0``.  With them the robot moves too, each capsule's ends in straight lines
        from their ``t0`` to their ``t1`` places; without, it is held where it is now (its motion within the
        step, up to 2.2 mm, then neither seen nor excused: a mover it kept clear of at t0 could read as a
        contact).  A mover whose box over the interval is not within ``below`` of ``robot_boxes`` (``(lo, hi)``,
        each (L, 3) [m], as for :meth:`clearance`; grown by how far the capsules moved) is not asked.
        """
        from navstack.sim.scene import BOX_SLACK, _link_capsules  # here: scene.py imports this module

        best = float(below)
        lo, hi = np.min(robot_boxes[0], axis=0), np.max(robot_boxes[1], axis=0)
        after, before, robot_rate = robot_capsules, previous_capsules, 0.0
        if before is not None:
            if after is None:
                after = _link_capsules(self.client, robot_id, self._capsules)
            moved = max(float(np.abs(before[0] - after[0]).max(initial=0.0)),
                        float(np.abs(before[1] - after[1]).max(initial=0.0)))
            lo, hi = lo - moved, hi + moved
            robot_rate = max(float(np.linalg.norm(before[0] - after[0], axis=1).max(initial=0.0)),
                             float(np.linalg.norm(before[1] - after[1], axis=1).max(initial=0.0))) / (t1 - t0)
        for m in self.movers:
            rate = m.motion.peak_speed + robot_rate
            n = math.ceil(rate * (t1 - t0) / SWEEP_STEP)
            if self._file_boxes is None or n == 0 or _still(m.motion, t0, t1):
                continue  # it did not move (a linear motion before its start or after its stop; amplitude 0)
            shifts = np.array([m.motion.displacement(t0 + (t1 - t0) * k / n) for k in range(n + 1)])
            box_lo = self._file_boxes[0][m.index] + shifts.min(axis=0) - SWEEP_STEP / 2  # between samples too
            box_hi = self._file_boxes[1][m.index] + shifts.max(axis=0) + SWEEP_STEP / 2
            gap = np.maximum(np.maximum(box_lo - hi, lo - box_hi), 0.0)
            if float(np.sqrt(gap @ gap)) - BOX_SLACK >= max(best, 0.0):
                continue  # it stays farther than what was already found
            if after is None:
                after = _link_capsules(self.client, robot_id, self._capsules)
            probe = self._mover_probe(m, after if before is None else before, after, t0, t1, max(best, 0.0) + MARGIN)
            found, _ = sampled_minimum(probe, t0, t1, n, rate, floor=0.0, resolution=SWEEP_RESOLUTION,
                                       max_extra=SWEEP_MAX_EXTRA)
            best = min(best, found)
            end = m.motion.displacement(t1)
            self.client.resetBasePositionAndOrientation(m.body, (m.position + end).tolist(), m.orientation)
            self._place_exact(m.index, end)
        return best

    def _mover_probe(self, m: _Mover, before: Capsules, after: Capsules, t0: float, t1: float,
                     reach: float) -> Callable[[float], tuple[float, float]]:
        """``t -> (distance, distance)`` (m), exact, from the robot's capsules at time ``t`` (their ends moved in
        straight lines from ``before`` at ``t0`` to ``after`` at ``t1``) to mover ``m`` placed at ``t`` (s), for
        :func:`~navstack.sim.lipschitz.sampled_minimum`; ``reach`` (m) when it is farther than that (only
        primitives farther than ``reach`` are left out, so it is a lower bound then)."""
        (a0, b0, r), (a1, b1, _) = before, after

        def probe(t: float) -> tuple[float, float]:
            w = (t - t0) / (t1 - t0)
            self._place_exact(m.index, m.motion.displacement(t))
            caps = (a0 + w * (a1 - a0), b0 + w * (b1 - b0), r)
            value = min((d for _, d in self._exact_distances(caps, [m.body], reach)), default=reach)
            return value, value

        return probe


def _still(motion: Motion, t0: float, t1: float) -> bool:
    """Whether ``motion`` leaves its obstacle where it is over the whole of ``[t0, t1]`` (s), from the motion
    itself: equal displacements at the even samples do not show it (a vibration whose period divides their
    spacing, phased so that every sample lands on its crest, read as still and its contacts were skipped)."""
    if motion.peak_speed == 0.0:
        return True
    return isinstance(motion, LinearMotion) and (t1 <= motion.start or t0 >= motion.stop)
