"""The controller's own tasks in one compiled call: the path memory's advance and :meth:`TaskSolver.step`
without the Python loop.

:class:`~navstack.control.solver.TaskSolver` calls each task's compiled row builder from Python: one
numba dispatch per task, each paying for its argument checks (about 0.5 us each: the difference between
a controller made of task objects and one kernel, ``tools/bench_control.py``).  For the tasks
:class:`~navstack.control.SlitherController` builds itself (tip, slither or none, posture, joint limits,
in that order) :func:`standard_step_into` runs the *same* kernels (the path memory's
:func:`~navstack.path.advance_into`, the tasks' row builders, the damping, equation (4)) in one call.
It adds no behaviour: ``tests/test_control.py`` checks it against the task-by-task path step by step.  A
controller given further tasks uses ``TaskSolver`` itself.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.control.damping import damping_lambda2, sigma_min
from navstack.control.equation4 import step_into
from navstack.control.solver import TaskSolver
from navstack.control.tasks import JointLimitTask, PostureTask, SlitherTask, TipTask
from navstack.control.tasks.base import kinematics_into
from navstack.control.tasks.limits import limit_rows_into
from navstack.control.tasks.posture import posture_rows_into
from navstack.control.tasks.slither import projected_rows_into, slither_rows_into
from navstack.control.tasks.tip import scaled_rows_into, tip_rows_into
from navstack.path import ADVANCE_FULL, ADVANCE_OK, PathMemory, advance_into

PATH_FAILED = 100
"""``standard_step_into`` returns ``PATH_FAILED + status`` when the path memory refused the command."""


@numba.njit(cache=True)
def standard_step_into(V, S, nv, head, iptr, pv, par, stats, x_d, xdot_d, reverse, L, spacing, tol,
                       dh, prismatic, point_frames, q, F, P, Jp,
                       w_tip, k_tip, form, w_sl, k_sl, joints, target, w_post, k_post, bounds3, w_lim, k_lim,
                       refresh, C, inv_sqrt_wv, G, lambda0, lambda_max, eps, dstate,
                       R, info, n_rows, wv, H, g, rate, qdot, bounds, dt):  # pragma: no cover - jitted
    """Path memory, kinematics, tip / slither (``form`` 0: none) / posture / limit rows, damping, equation (4).

    The argument groups are those of :func:`~navstack.path.advance_into`, :func:`kinematics_into`, the
    four tasks' row builders, the damping and :func:`step_into`, in that order.  Returns ``step_into``'s
    status, or ``PATH_FAILED + status`` (nothing changed) if the path memory refused the command.
    """
    status = advance_into(V, S, nv, head, iptr, pv, par, stats, x_d, xdot_d, reverse, L, spacing, tol)
    if status != ADVANCE_OK:
        return PATH_FAILED + status
    yd, ydot = pv[0], pv[1]
    kinematics_into(dh, prismatic, point_frames, q, F, P, Jp)
    tip_rows_into(P, Jp, x_d, xdot_d, w_tip, k_tip, R, info, 0)
    r = 3
    if form != 0:
        slither_rows_into(P, Jp, x_d, yd, ydot, form, w_sl, k_sl, R, info, r)
        r += (2 if form == 1 else 3) * yd.shape[0]
    posture_rows_into(q, joints, target, w_post, k_post, info, r)
    limit_rows_into(q, bounds3, w_lim, k_lim, info, r + joints.shape[0])
    if refresh:
        scaled_rows_into(Jp[0], math.sqrt(w_tip), C, 0)
        if form != 0:
            projected_rows_into(Jp, x_d, yd, math.sqrt(w_sl), C, 3)
        sigma = sigma_min(C, C.shape[0], inv_sqrt_wv, G)
        dstate[0] = sigma
        dstate[1] = damping_lambda2(sigma, lambda0, lambda_max, eps)
    return step_into(R, info, n_rows, wv, dstate[1], H, g, rate, q, qdot, bounds, dt)


class StandardStep:
    """One controller step for ``solver``'s tasks ``tip, [slither], posture, limits`` in one call.

    ``path`` is the path memory the step advances (the slither task's, or the controller's own when
    there is no slither task); ``reverse_tolerance`` [m] as for :meth:`PathMemory.advance`.
    """

    def __init__(self, solver: TaskSolver, path: PathMemory, reverse_tolerance: float) -> None:
        tasks = solver.tasks
        kinds = (TipTask, SlitherTask, PostureTask, JointLimitTask) if len(tasks) == 4 else \
            (TipTask, PostureTask, JointLimitTask)
        if len(tasks) != len(kinds) or not all(type(t) is k for t, k in zip(tasks, kinds, strict=True)):
            raise TypeError(f"StandardStep needs the tasks tip, [slither], posture, limits; got "
                            f"{[type(t).__name__ for t in tasks]}")
        self.solver = solver
        self.tip, self.posture, self.limits = tasks[0], tasks[-2], tasks[-1]
        self.slither = tasks[1] if len(tasks) == 4 else None
        if self.slither is not None and self.slither.path is not path:
            raise ValueError("StandardStep: path must be the slither task's path memory")
        self.path = path
        self.tolerance = float(reverse_tolerance)
        self._form = 0 if self.slither is None else self.slither._form
        kin = solver.kin
        self._chain = (kin._dh, solver.chain.prismatic, solver.chain.point_frames)
        self._frames = (kin.F, kin.P, kin.Jp)
        d = solver.damping
        self._damping = (d.C, d._inv_sqrt_wv, d._G, d.lambda0, d.lambda_max, d.eps, d.state)

    def __call__(self, x_d: NDArray[np.float64], xdot_d: NDArray[np.float64], reverse: bool,
                 q: NDArray[np.float64], qdot: NDArray[np.float64], bounds: NDArray[np.float64], dt: float) -> int:
        """The slither task's ``set_target`` (or the path's ``advance``), the tip's ``set_target``, then
        ``solver.step(q, qdot, bounds, dt)``; raises the path memory's ``ValueError`` (nothing changed) if it
        refuses the command.  Returns the status of :func:`step_into`."""
        status = self._call(x_d, xdot_d, reverse, q, qdot, bounds, dt)
        if status == PATH_FAILED + ADVANCE_FULL:
            self.path.ensure_capacity(2)
            status = self._call(x_d, xdot_d, reverse, q, qdot, bounds, dt)
        if status >= PATH_FAILED:  # the path refused: its own call raises the error, changing nothing
            self.path.advance(x_d, xdot_d, reverse, self.tolerance)
            raise AssertionError(f"the path memory refused a command it then accepted (status {status})")
        self.tip.set_target(x_d, xdot_d)
        if self.slither is not None:
            self.slither.x_d = x_d
        return status

    def _call(self, x_d: NDArray[np.float64], xdot_d: NDArray[np.float64], reverse: bool, q: NDArray[np.float64],
              qdot: NDArray[np.float64], bounds: NDArray[np.float64], dt: float) -> int:
        s, tip, sl, post, lim = self.solver, self.tip, self.slither, self.posture, self.limits
        refresh = s.steps % s.damping.every == 0
        w_sl, k_sl = (sl.weight, sl.gain) if sl is not None else (0.0, 0.0)
        status = standard_step_into(*self.path.kernel_state, x_d, xdot_d, reverse, self.path.link_length,
                                    self.path.spacing, self.tolerance, *self._chain, q, *self._frames,
                                    tip.weight, tip.gain, self._form, w_sl, k_sl,
                                    post.joints, post.target, post.weight, post.gain,
                                    lim.bounds, lim.weight, lim.gain,
                                    refresh, *self._damping,
                                    s.R, s.info, s.n_rows, s.wv, s._H, s._g, s.rate, qdot, bounds, dt)
        if status < PATH_FAILED:
            s.steps += 1
            s.kin.q = q
        return status
