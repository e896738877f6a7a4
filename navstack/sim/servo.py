"""Joint servo: PyBullet position control tracking theta_d(t), with gravity feed-forward.

The paper assumes "low-level joint servo-loops capable of ensuring that the
robot joint-space position remains close to any desired trajectory
theta_d(t)".  Here that is PyBullet's ``POSITION_CONTROL`` motor on every
joint, with explicit per-joint force limits and gains, fed both the desired
position and the desired velocity (feed-forward), plus a gravity feed-forward
torque.

Gravity compensation
    PyBullet's motors are velocity constraints solved iteratively; alone they
    hold a 20-joint arm against gravity with a static droop (0.93 mm at the
    joint points at the start posture, 0.83 mm over the demo).  Each physics
    step therefore also applies, with ``TORQUE_CONTROL`` (an extra joint torque
    for that one step; the position motors stay on), the holding torques at the
    set-point: ``tau_g(q) = -sum_i m_i J_i(q)^T g``, ``m_i`` the mass of link
    ``i`` (read from PyBullet), ``J_i`` the position Jacobian of its centre of
    mass (the origin of its DH frame, where :mod:`navstack.sim.body` puts it)
    and ``g`` the gravity in the base frame.  That is
    ``calculateInverseDynamics(q, 0, 0)`` with the base's orientation taken into
    account: PyBullet's own inverse dynamics ignores a rotated fixed base and
    applies gravity along the base's -z (bullet3 issue 2876; for the demo's
    base, along the lathe bed), so it is not used.  With ``tau_g`` alone
    (motors off) the robot stays still at its start posture (tests/test_body.py).

Rates: physics at ``physics_hz`` (default 240 Hz), the controller at
``control_hz`` (default 30 Hz); one control step = ``substeps`` physics steps.
Within a control period the set-point is interpolated linearly from the
previous theta_d to the new one (a first-order hold), so the motors never see
a stale position paired with a non-zero velocity.  Each physics step gets the
set-point of its start plus the desired rate, which PyBullet's velocity-level
motor integrates across the step.  The interpolation earns its cost (issue 11, measured on the paper demo,
``truss_clutter.json`` and ``slot_rack.json``, seed 0): with the new theta_d held over the whole period
instead (one motor command per control step), the tip error grows from 0.03 mm to 0.51-0.54 mm, the joint
error from 3e-6 to 1.2-2.0e-3 rad, the slot rack's minimum clearance drops from 14.5 to 6.3 mm, and the
trial is 1.3-1.4x *slower*: PyBullet's solver needs more iterations to follow the jumpy set-point than
the Python of eight commands costs.  The eight set-points and their holding torques are computed in one
call each (:meth:`GravityTorques.many`).
Gravity is on (-9.81 m/s^2 along world z): the testbed is on the ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike

from navstack.kinematics import Chain, frames_into, point_jacobians_into
from navstack.sim._bullet import pybullet
from navstack.sim.body import RobotBody
from navstack.validate import finite, flag, in_range, integer, positive


@numba.njit(cache=True)
def _gravity_torques_into(alpha, a, d, theta, prismatic, frames, weights, qs, F, J, out):  # pragma: no cover
    """``out[k] = -sum_i sum_c weights[i, c] J_i(qs[k])[c, :]`` for every row of ``qs``: the holding torques
    of :class:`GravityTorques`, summed in ``numpy.einsum``'s order (i, then c), so bit-equal to it."""
    n = qs.shape[1]
    for k in range(qs.shape[0]):
        frames_into(alpha, a, d, theta, prismatic, qs[k], F)
        point_jacobians_into(F, prismatic, frames, J)
        for j in range(n):
            acc = 0.0
            for i in range(weights.shape[0]):
                for c in range(3):
                    acc += weights[i, c] * J[i, c, j]
            out[k, j] = -acc


class GravityTorques:
    """Joint torques [N, N m] that hold ``chain`` still against gravity: ``-sum_i m_i J_i(q)^T g``.

    ``masses[i]`` [kg] is the mass of the body carrying DH frame ``i + 1`` (PyBullet link ``i``), its
    centre of mass at that frame's origin; ``gravity`` (3,) [m/s^2] is in the base frame.
    """

    def __init__(self, chain: Chain, masses: ArrayLike, gravity: ArrayLike) -> None:
        self.chain = chain
        self.masses = np.asarray(masses, dtype=np.float64)
        if self.masses.shape != (len(chain.alpha),):
            raise ValueError(f"masses must have one value per DH row ({len(chain.alpha)}), got {self.masses.shape}")
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self._frames = np.arange(1, len(chain.alpha) + 1, dtype=np.int64)
        self._F = np.empty((chain.n_frames, 4, 4))
        self._J = np.empty((len(self._frames), 3, chain.n))
        self._weights = self.masses[:, None] * self.gravity[None, :]  # m_i g

    def __call__(self, q: ArrayLike) -> np.ndarray:
        ch = self.chain
        frames_into(ch.alpha, ch.a, ch.d, ch.theta, ch.prismatic, np.asarray(q, dtype=np.float64), self._F)
        point_jacobians_into(self._F, ch.prismatic, self._frames, self._J)
        return -np.einsum("ic,icj->j", self._weights, self._J)

    def many(self, qs: np.ndarray) -> np.ndarray:
        """The torques (K, n) at each row of ``qs`` (K, n) (float64, C-contiguous): one compiled call, the
        same numbers as calling the object row by row."""
        ch = self.chain
        out = np.empty(qs.shape)
        _gravity_torques_into(ch.alpha, ch.a, ch.d, ch.theta, ch.prismatic, self._frames, self._weights, qs,
                              self._F, self._J, out)
        return out


@dataclass(frozen=True)
class ServoConfig:
    """Servo and simulation rates, gains and force limits.

    Forces are N for the lathe bed and N m for the revolute joints.  Gains are
    PyBullet's dimensionless motor gains (``positionGain``/``velocityGain``).
    """

    physics_hz: float = 240.0
    control_hz: float = 30.0
    position_gain: float = 0.6
    velocity_gain: float = 1.0
    lathe_force: float = 5000.0
    arm_torque: float = 2000.0
    serpentine_torque: float = 200.0
    gravity: float = -9.81
    solver_iterations: int = 100
    gravity_compensation: bool = True
    """Add the holding torques at the set-point to every joint (module docstring)."""

    def __post_init__(self) -> None:
        positive(self, "physics_hz", "control_hz", "lathe_force", "arm_torque", "serpentine_torque")
        in_range(self, "position_gain", "velocity_gain", lo=0.0, hi=1.0, lo_open=True)
        finite(self, "gravity")
        integer(self, "solver_iterations", lo=1)
        flag(self, "gravity_compensation")
        ratio = self.physics_hz / self.control_hz
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"ServoConfig: physics_hz ({self.physics_hz}) must be a whole multiple"
                f" of control_hz ({self.control_hz})"
            )

    @property
    def substeps(self) -> int:
        """Physics steps per control step."""
        return round(self.physics_hz / self.control_hz)

    @property
    def control_dt(self) -> float:
        """Control period [s]."""
        return 1.0 / self.control_hz


class JointServo:
    """Tracks (theta_d, thetadot_d) on every joint of ``body``."""

    def __init__(self, body: RobotBody, config: ServoConfig = ServoConfig()) -> None:
        self.body = body
        self.config = config
        n = body.chain.n
        forces = np.full(n, config.arm_torque)
        forces[body.chain.prismatic] = config.lathe_force
        forces[8:] = config.serpentine_torque
        self.forces = forces.tolist()
        self.kp = [config.position_gain] * n
        self.kd = [config.velocity_gain] * n
        client = body.client
        self._joints = body.joint_indices
        # the client's calls looked up once (a BulletClient builds a new partial on every attribute access)
        self._motors = client.setJointMotorControlArray
        self._step = client.stepSimulation
        self._fractions = (np.arange(config.substeps) / config.substeps)[:, None]
        """(substeps, 1): ``i / substeps``, the set-point's fraction of the way at the start of physics step i."""
        client.setTimeStep(1.0 / config.physics_hz)
        client.setGravity(0.0, 0.0, config.gravity)
        client.setPhysicsEngineParameter(numSubSteps=0, numSolverIterations=config.solver_iterations)
        self._prev: np.ndarray | None = None
        self._target = np.zeros(n)
        self._rate = np.zeros(n)
        self.gravity_torques: GravityTorques | None = None
        if config.gravity_compensation:
            links = range(len(body.chain.alpha))
            info = [client.getDynamicsInfo(body.body_id, link) for link in links]
            offset = max(float(np.abs(i[3]).max()) for i in info)
            if offset > 1e-12:  # the model below puts every centre of mass at its frame's origin
                raise ValueError(f"gravity compensation needs link centres of mass at the frame origins "
                                 f"(offset {offset} m)")
            g_base = body.base_transform[:3, :3].T @ np.array([0.0, 0.0, config.gravity])
            self.gravity_torques = GravityTorques(body.chain, [i[0] for i in info], g_base)

    def hold(self, q: ArrayLike) -> None:
        """Start from rest at ``q`` (the first command interpolates from here)."""
        self._prev = self.body.chain.check(q).copy()
        self._target = self._prev.copy()
        self._rate = np.zeros_like(self._prev)

    def command(self, theta_d: ArrayLike, thetadot_d: ArrayLike) -> None:
        """Set the set-point reached at the end of the next control period.

        Raises ``ValueError`` on a wrong length or a non-finite value: NaN never reaches the motors.
        """
        q = self.body.chain.check(theta_d)
        qd = np.asarray(thetadot_d, dtype=np.float64)
        if qd.shape != q.shape or not np.isfinite(qd).all():
            raise ValueError("thetadot_d must be 20 finite joint rates")
        if self._prev is None:
            self._prev = q.copy()
        else:
            self._prev = self._target
        self._target = q.copy()
        self._rate = qd.copy()

    def step(self) -> None:
        """Advance the physics by one control period, interpolating the set-point."""
        if self._prev is None:
            raise RuntimeError("JointServo.step() before hold() or command()")
        # the set-point at the START of each physics step i (prev + (target - prev) * i / n, all steps at
        # once); the motor's velocity target carries the joint across the step (measured: this removes the
        # one-step overshoot that an end-of-step target produces)
        setpoints = self._prev + (self._target - self._prev) * self._fractions
        targets = setpoints.tolist()
        rate = self._rate.tolist()
        torques = None if self.gravity_torques is None else self.gravity_torques.many(setpoints).tolist()
        body, joints, motors, physics_step = self.body.body_id, self._joints, self._motors, self._step
        position, torque = pybullet.POSITION_CONTROL, pybullet.TORQUE_CONTROL
        forces, kp, kd = self.forces, self.kp, self.kd
        for i in range(len(targets)):
            motors(body, joints, position, targetPositions=targets[i], targetVelocities=rate, forces=forces,
                   positionGains=kp, velocityGains=kd)
            if torques is not None:  # an extra torque for this step; the motors stay on
                motors(body, joints, torque, forces=torques[i])
            physics_step()
