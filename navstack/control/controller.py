"""The slithering controller: the tasks of equation (4) for the JPL robot, solved and integrated.

:class:`SlitherController` builds, from a :class:`~navstack.control.config.ControlConfig`, the tasks
tip, slither (unless ``slither="none"``: the ``tip-only`` baseline), posture and joint limits (in that
order), and a :class:`~navstack.control.solver.TaskSolver`.  Each :meth:`SlitherController.step`:

1. gives the tip task the desired tip and the slither task the desired tip (its path memory records it,
   or, for a reverse command, is cut back to it; without slither rows the controller advances a path
   memory of its own, which the trial's metrics and retraction read),
2. solves equation (4) at ``theta_d(t)`` (the kinematic loop: the tasks see ``z = f(theta_d)``),
3. integrates ``theta_d(t + dt) = theta_d(t) + dt * thetadot_d`` (explicit Euler) and clips it into the
   joint limits.

The normal matrix is symmetric positive definite (``lambda0 > 0``, ``W_v > 0``), so with finite inputs
(checked: ``ValueError``, nothing recorded) the rate is finite; if a non-finite rate ever appears the
step raises :class:`ControlError` and ``theta_d`` keeps its previous value (the path memory has
recorded ``x_d``), so a non-finite ``theta_d`` is never returned.  The controller reads only the desired
tip motion and its own state, never obstacle geometry.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.control.config import ControlConfig
from navstack.control.damping import AdaptiveDamping
from navstack.control.equation4 import STEP_NONFINITE, STEP_OK
from navstack.control.fast import StandardStep
from navstack.control.solver import TaskSolver
from navstack.control.tasks import JointLimitTask, PostureTask, SlitherTask, Task, TaskRows, TipTask
from navstack.jpl import ARM_JOINTS, LINK_LENGTH, N_JOINTS
from navstack.kinematics import Chain
from navstack.path import PathMemory


class ControlError(RuntimeError):
    """The controller could not produce a finite joint rate (state left unchanged)."""


def _posture_and_margins(chain: Chain, cfg: ControlConfig, q0: NDArray[np.float64]
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The arm posture [rad] (``cfg.posture`` or ``q0``'s) and the per-joint limit margins, checked
    against ``chain``'s limits (``ValueError`` naming the ``ControlConfig`` field)."""
    posture = q0[ARM_JOINTS] if cfg.posture is None else np.asarray(cfg.posture, dtype=np.float64)
    outside = np.flatnonzero((posture < chain.lower[ARM_JOINTS]) | (posture > chain.upper[ARM_JOINTS]))
    if outside.size:
        j = int(ARM_JOINTS[outside[0]])
        raise ValueError(f"ControlConfig.posture for joint {j + 1} = {posture[outside[0]]} is outside its "
                         f"limits [{chain.lower[j]}, {chain.upper[j]}]")
    margin = np.where(chain.prismatic, cfg.limit_margin_prismatic, cfg.limit_margin)
    tight = np.flatnonzero(2.0 * margin >= chain.upper - chain.lower)
    if tight.size:
        j = int(tight[0])
        name = "limit_margin_prismatic" if chain.prismatic[j] else "limit_margin"
        raise ValueError(f"ControlConfig.{name}={margin[j]} leaves no free range for joint {j + 1} "
                         f"(range {chain.upper[j] - chain.lower[j]})")
    return posture, margin


class SlitherController:
    """Equation (4) slithering controller for the 20-DOF JPL robot (see the module docstring).

    ``SlitherController(chain, config, q0)`` starts with ``theta_d = q0`` and a
    :class:`PathMemory` holding ``q0``'s backbone.  ``extra_tasks`` are stacked after the built-in ones
    (e.g. obstacle limits; each a :class:`~navstack.control.tasks.Task`, with its targets kept by the
    caller; a task with conditioning rows adds them to the damping's singular value).
    """

    def __init__(self, chain: Chain, config: ControlConfig | None = None, q0: ArrayLike | None = None,
                 extra_tasks: Sequence[Task] = ()) -> None:
        cfg = ControlConfig() if config is None else config
        if not isinstance(chain, Chain):
            raise TypeError(f"chain must be a navstack Chain (navstack.jpl_serpentine()), got {type(chain).__name__}")
        if not isinstance(cfg, ControlConfig):
            raise TypeError(f"config must be a ControlConfig, got {type(cfg).__name__}")
        if chain.n != N_JOINTS or len(chain.point_frames) != 7:
            raise ValueError(
                f"SlitherController needs the JPL layout (20 joints, 7 backbone points), got chain "
                f"{chain.name!r} with {chain.n} joints and {len(chain.point_frames)} points"
            )
        q = chain.check(chain.q_default if q0 is None else q0).copy()
        out_of = np.flatnonzero((q < chain.lower) | (q > chain.upper))
        if out_of.size:
            j = int(out_of[0])
            raise ValueError(
                f"q0[{j}] (joint {j + 1}) = {q[j]} is outside its limits [{chain.lower[j]}, {chain.upper[j]}]"
            )
        self.chain = chain
        self.config = cfg
        self._q = q
        self._qdot = np.zeros(chain.n)
        self._bounds = np.ascontiguousarray(np.stack([chain.lower, chain.upper]))
        backbone = chain.points_and_jacobians(q)[0]
        self.path = PathMemory(backbone, link_length=LINK_LENGTH, spacing=cfg.path_spacing)
        """The recorded tip path (the slither task's, when there is one)."""
        self.tip = TipTask(cfg.w_tip, cfg.k_tip)
        self.tip.set_target(backbone[0].copy(), np.zeros(3))
        self.slither = None if cfg.slither == "none" else SlitherTask(
            self.path, cfg.slither, cfg.w_slither, cfg.k_slither, cfg.reverse_tolerance)
        posture, margin = _posture_and_margins(chain, cfg, q)
        self.posture_task = PostureTask(ARM_JOINTS, posture, cfg.w_posture, cfg.k_posture)
        self.limits = JointLimitTask(chain.lower, chain.upper, margin, cfg.w_limit, cfg.k_limit)
        tasks = [self.tip] + ([self.slither] if self.slither else []) + [self.posture_task, self.limits]
        extra = tuple(extra_tasks)
        if not all(isinstance(t, Task) for t in extra):
            raise TypeError(f"extra_tasks must be Task objects, got {[type(t).__name__ for t in extra]}")
        tasks += list(extra)
        wv = np.asarray(cfg.wv, dtype=np.float64)
        damping = AdaptiveDamping(cfg.lambda0, cfg.lambda_max, cfg.sigma_eps, cfg.sigma_every, wv,
                                  rows=sum(t.conditioning_size for t in tasks))
        self.solver = TaskSolver(chain, tasks, wv, damping)
        # the built-in tasks alone: the same kernels in one compiled call (navstack/control/fast.py)
        self._fast = None if extra else StandardStep(self.solver, self.path, cfg.reverse_tolerance)
        tol = cfg.reverse_tolerance
        self._track = self.slither.set_target if self.slither else (
            lambda x, xd, reverse: self.path.advance(x, xd, reverse, tol))
        self._dt = cfg.dt
        self._steps = 0

    # ---- state ---------------------------------------------------------
    @property
    def theta_d(self) -> NDArray[np.float64]:
        """Desired joint positions (copy) [m for joint 1, rad otherwise]."""
        return self._q.copy()

    @property
    def thetadot_d(self) -> NDArray[np.float64]:
        """Effective joint rates of the last step, ``(theta_d(t+dt) - theta_d(t)) / dt`` (copy) [m/s, rad/s].

        Equal to equation (4)'s rate except for joints clipped at a limit
        (see :attr:`rate_eq4`); a servo velocity feed-forward.
        """
        return self._qdot.copy()

    @property
    def rate_eq4(self) -> NDArray[np.float64]:
        """Equation (4)'s rate of the last step, before clipping (copy) [m/s, rad/s]."""
        return self.solver.rate.copy()

    @property
    def desired_points(self) -> NDArray[np.float64]:
        """The last desired joint points y_d (6, 3) [m], J1 first (copy)."""
        return self.path.pts.copy()

    @property
    def desired_velocities(self) -> NDArray[np.float64]:
        """The last desired joint-point velocities (6, 3) [m/s] (copy)."""
        return self.path.vel.copy()

    @property
    def lam2(self) -> float:
        """lambda^2 used by the last step."""
        return self.solver.damping.lam2

    @property
    def lam(self) -> float:
        """Damping lambda of the last step (sqrt of the adaptive lambda^2)."""
        return math.sqrt(self.lam2)

    @property
    def sigma_min(self) -> float:
        """Smallest singular value of the weighted task Jacobian (last refresh)."""
        return self.solver.damping.sigma

    @property
    def steps(self) -> int:
        """Number of completed steps."""
        return self._steps

    @property
    def posture(self) -> NDArray[np.float64]:
        """The arm posture held by the posture task (7,) [rad]."""
        return self.posture_task.target.copy()

    @property
    def wv(self) -> NDArray[np.float64]:
        """Diagonal of W_v (20,)."""
        return self.solver.wv.copy()

    # ---- stepping ------------------------------------------------------
    def step(self, x_d: ArrayLike, xdot_d: ArrayLike, reverse: bool = False) -> NDArray[np.float64]:
        """Advance one period with desired tip ``x_d`` [m] and velocity ``xdot_d`` [m/s]; returns theta_d (copy).

        Both are in the robot's base frame (DH frame 0) at time ``t``.  The rate
        of (4) is evaluated at ``theta_d(t)`` and integrated, so the returned
        ``theta_d(t + dt)`` has ``f(theta_d(t + dt)) ~ x_d(t) + dt * xdot_d(t)``:
        the servo target for the end of the period.  ``reverse=True``: ``x_d`` lies on the recorded path
        behind its end (the tip retracing its path, :mod:`navstack.retreat`); the path memory is cut back
        to it instead of recording it.

        Raises ``ValueError`` for a non-3-vector or non-finite input, or a reverse ``x_d`` off the
        recorded path (nothing is recorded then), and :class:`ControlError` if no finite rate results.
        """
        try:  # one fresh (2, 3) array: x and xd are its rows (the tasks keep them)
            both = np.array((x_d, xdot_d), dtype=np.float64)
        except ValueError:
            both = np.empty(0)
        if both.shape != (2, 3):
            for name, v, unit in (("x_d", x_d, "m"), ("xdot_d", xdot_d, "m/s")):
                shape = np.shape(v)
                if shape != (3,):
                    raise ValueError(f"{name} must be a 3-vector [{unit}], got shape {shape}")
        x, xd = both[0], both[1]
        try:
            if self._fast is not None:
                status = self._fast(x, xd, reverse, self._q, self._qdot, self._bounds, self._dt)
            else:
                self._track(x, xd, reverse)
                self.tip.set_target(x, xd)
                status = self.solver.step(self._q, self._qdot, self._bounds, self._dt)
        except ValueError as exc:
            for name, v, unit in (("x_d", x, "m"), ("xdot_d", xd, "m/s")):
                if not np.isfinite(v).all():
                    raise ValueError(f"{name} must be finite [{unit}], got {v.tolist()} at step {self._steps}") \
                        from None
            raise ValueError(f"{exc} (at step {self._steps})") from None
        if status != STEP_OK:
            rate = self.solver.rate
            bad = np.flatnonzero(~np.isfinite(rate))
            what = f"joint {int(bad[0]) + 1} rate is {rate[bad[0]]}" if status == STEP_NONFINITE and bad.size \
                else "normal matrix not SPD"
            raise ControlError(f"equation (4) gave no finite rate at step {self._steps} ({what}); theta_d held")
        self._steps += 1
        return self._q.copy()

    def tasks(self, q: ArrayLike | None = None) -> TaskRows:
        """The stacked task rows at ``q`` (default ``theta_d``) for the last desired tip and chain points.

        For inspection and tests; does not change the controller's state.
        """
        return self.solver.stack(self.chain.check(self._q if q is None else q))
