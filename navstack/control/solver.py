"""The solver: stacks the tasks' rows and solves equation (4) for the joint rate.

Per call of :meth:`TaskSolver.solve` at a configuration ``q``: the kinematics once
(:class:`~navstack.control.tasks.Kinematics`), every task fills its block of rows, in the order given
(:meth:`~navstack.control.tasks.Task.fill`); on a refresh step the adaptive damping gathers the
conditioning rows and recomputes lambda (:mod:`navstack.control.damping`); then equation (4)
(:func:`navstack.control.equation4.solve_rows_into`).  The tasks hold their own targets, set before.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from navstack.control.damping import AdaptiveDamping
from navstack.control.equation4 import solve_rows_into, step_into
from navstack.control.tasks.base import I_COL, N_INFO, Kinematics, Task, TaskRows
from navstack.kinematics import Chain


class TaskSolver:
    """Equation (4) over ``tasks`` (stacked in order) with ``W_v = diag(wv)`` and adaptive ``damping``."""

    def __init__(self, chain: Chain, tasks: Sequence[Task], wv: NDArray[np.float64],
                 damping: AdaptiveDamping) -> None:
        self.chain = chain
        self.tasks = tuple(tasks)
        names = [t.name for t in self.tasks]
        if len(set(names)) != len(names):
            raise ValueError(f"task names must be unique, got {names}")
        self.wv = np.ascontiguousarray(wv, dtype=np.float64)
        self.damping = damping
        self.kin = Kinematics(chain)
        offsets = np.cumsum([0] + [t.size for t in self.tasks])
        self._fills = tuple((t.fill, int(r0)) for t, r0 in zip(self.tasks, offsets[:-1], strict=True))
        self.n_rows = int(offsets[-1])
        cond = [t for t in self.tasks if t.conditioning_size > 0]
        c_off = np.cumsum([0] + [t.conditioning_size for t in cond])
        if c_off[-1] != damping.C.shape[0]:
            raise ValueError(f"damping expects {damping.C.shape[0]} conditioning rows, the tasks give {c_off[-1]}")
        self._conditioning = tuple((t.conditioning, int(r0)) for t, r0 in zip(cond, c_off[:-1], strict=True))
        n = chain.n
        self.R = np.zeros((max(self.n_rows, 1), n))
        self.info = np.zeros((N_INFO, max(self.n_rows, 1)))
        self.info[I_COL] = -1.0
        self._H = np.empty((n, n))
        self._g = np.empty(n)
        self.rate = np.zeros(n)
        """Equation (4)'s rate of the last :meth:`solve` [m/s, rad/s]."""
        self.steps = 0

    def build(self, q: NDArray[np.float64]) -> None:
        """The stacked rows at ``q``: kinematics, every task's rows, the damping (on a refresh step)."""
        kin = self.kin
        kin.update(q)
        R, info = self.R, self.info
        for fill, r0 in self._fills:
            fill(kin, R, info, r0)
        damping = self.damping
        if self.steps % damping.every == 0:
            for conditioning, r0 in self._conditioning:
                conditioning(kin, damping.C, r0)
            damping.refresh()
        self.steps += 1

    def solve(self, q: NDArray[np.float64]) -> bool:
        """Rate of equation (4) at ``q`` into :attr:`rate`; False if the normal matrix was not SPD."""
        self.build(q)
        return solve_rows_into(self.R, self.info, self.n_rows, self.wv, self.damping.lam2, self._H, self._g,
                               self.rate)

    def step(self, q: NDArray[np.float64], qdot: NDArray[np.float64], bounds: NDArray[np.float64],
             dt: float) -> int:
        """:meth:`solve` at ``q``, then ``q += dt * rate`` in place, clipped into ``bounds`` (2, n), ``qdot`` the
        effective rate (:func:`~navstack.control.equation4.step_into`); returns its status (0: done)."""
        self.build(q)
        return step_into(self.R, self.info, self.n_rows, self.wv, self.damping.lam2, self._H, self._g, self.rate,
                         q, qdot, bounds, dt)

    def stack(self, q: NDArray[np.float64]) -> TaskRows:
        """Every task's rows at ``q``, stacked (fresh arrays; changes no state)."""
        kin = Kinematics(self.chain)
        kin.update(np.array(q, dtype=np.float64))
        parts = [t.rows(kin) for t in self.tasks]
        return TaskRows(*(np.concatenate([getattr(p, f) for p in parts])
                          for f in ("J", "z", "z_d", "zdot_d", "w", "k")),
                        names=tuple(nm for p in parts for nm in p.names))
