"""``min_clearance`` beyond the per-step horizon: the recorded trial replayed where it could matter.

Each control step asks PyBullet for the robot's clearance only up to ``TrialConfig.clearance_horizon``
(0.5 m; farther bodies cost nothing), which is exact whenever something comes that close.  A trial that
never does would report the horizon, not the spec's "robot surface to obstacle surface" minimum; so
after such a trial :func:`replay_min_clearance` measures the recorded steps again without a horizon.

It need not measure every step.  Every collision shape of the robot is a capsule between two DH frame
origins (interfaces.md section 1), so no point of the robot's surface moves farther between two steps
than the farthest-moving origin; a mover moves at most its ``peak_speed`` times the time.  A signed
distance changes by no more than the surfaces move, so after measuring ``d_j`` at step ``j`` a later step
``k`` cannot come below ``d_j - (origins' largest displacement) - (movers' peak speed) x (t_k - t_j + dt)``
(the ``dt``: the movers are swept over the step before ``k``, as in the trial, the robot moving from step
``k - 1``'s place to ``k``'s, so its displacement is the larger of the two steps'), less PyBullet's
:data:`~navstack.sim.exact_distance.MARGIN` (its distance to a box corner may read that much high where it
is not sharpened).  Steps whose bound is not
below the smallest clearance found so far are skipped; the result is the same minimum as measuring every
step.  In free space, far from everything, a few measurements cover the whole trial.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.sim.exact_distance import MARGIN

FAR = 1.0e4
"""m: the replay's farthest query, beyond any two surfaces of a valid world (coordinates within 1 km)."""

_CHUNK = 256
"""Steps whose bounds are computed at once."""


def replay_min_clearance(scene: Any, body: Any, qs: NDArray[np.float64], origins: NDArray[np.float64],
                         times: NDArray[np.float64], dt: float) -> float:
    """The smallest clearance (m) of the robot over the recorded control steps, as the trial measures it
    (robot at ``qs[k]``, movers at ``times[k]`` and swept over the step before), without a horizon.

    ``scene``: the trial's :class:`~navstack.sim.scene.Scene`; ``body``: its
    :class:`~navstack.sim.body.RobotBody`; ``qs`` (T, 20) the measured joints; ``origins`` (T, 21, 3) [m] the
    world positions of DH frames 1..21 at each step; ``times`` (T,) [s]; ``dt`` [s] the control period.
    +inf when the scene has no obstacles.  Leaves the robot's joints and the movers as the last step had
    them (velocities zero).
    """
    n = len(qs)
    if n == 0 or not scene.body_ids:
        return math.inf
    speed = max((m.motion.peak_speed for m in scene.movers), default=0.0)
    best, j = math.inf, 0
    while j < n:
        here = _measure(scene, body, qs[j], origins[j], origins[j - 1] if j else None, times, j, dt, best)
        best = min(best, here)
        j = _next_step(origins, times, j, here, best, speed, dt)
    _place(scene, body, qs[n - 1], times[n - 1])
    return best


def _next_step(origins: NDArray[np.float64], times: NDArray[np.float64], j: int, here: float, best: float,
               speed: float, dt: float) -> int:
    """The first step after ``j`` whose lower bound (module docstring) is below ``best``, or T."""
    n = len(origins)
    k = j + 1
    while k < n:
        stop = min(k + _CHUNK, n)
        moved = np.sqrt(((origins[k - 1:stop] - origins[j]) ** 2).sum(axis=2)).max(axis=1)
        moved = np.maximum(moved[1:], moved[:-1])  # the swept check moves the robot from step k - 1 to k
        bound = here - MARGIN - moved - speed * (times[k:stop] - times[j] + dt)  # ``here`` may read MARGIN high
        low = np.flatnonzero(bound < best)
        if len(low):
            return k + int(low[0])
        k = stop
    return n


def _place(scene: Any, body: Any, q: NDArray[np.float64], t: float) -> None:
    body.reset(q)
    scene.update(t)
    body.client.performCollisionDetection()


def _measure(scene: Any, body: Any, q: NDArray[np.float64], origins: NDArray[np.float64],
             before: NDArray[np.float64] | None, times: NDArray[np.float64], k: int, dt: float, best: float) -> float:
    """The trial's clearance at step ``k`` (``Simulation._measure``; ``before``: the frame origins of step
    ``k - 1``, for the swept check), exact below ``best`` and without a horizon.

    The query distance doubles from 1 m until something lies within it: PyBullet returns a closest point for
    every triangle of a mesh within the distance, and one query of 10 km around a 5,120-triangle mesh crashed
    it (a segmentation fault)."""
    _place(scene, body, q, times[k])
    boxes, capsules = body.link_boxes(origins), body.capsules(origins)
    record = min(best, FAR)
    reach = 1.0
    while True:
        clearance = scene.clearance(body.body_id, reach, boxes, record, capsules)
        if clearance < reach or reach >= FAR:
            break
        reach = min(2.0 * reach, FAR)
    if scene.movers and k and before is not None:
        clearance = scene.swept_clearance(body.body_id, times[k] - dt, times[k], clearance, boxes, capsules,
                                          body.capsules(before))
    return float(clearance)
