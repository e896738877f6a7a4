"""The tasks of equation (4), one by one: each task's Jacobian rows against finite differences of its own
task coordinate z(q), its errors and weights, and the solver that stacks them (a new task needs no edit
of the solver)."""

from __future__ import annotations

import numpy as np
import pytest

from navstack import jpl_serpentine
from navstack.control import dls_rate
from navstack.control.damping import AdaptiveDamping
from navstack.control.solver import TaskSolver
from navstack.control.tasks import JointLimitTask, Kinematics, PostureTask, SlitherTask, Task, TipTask
from navstack.control.tasks.base import I_COL, I_K, I_W, I_Z, I_ZD, I_ZDOT
from navstack.jpl import ARM_JOINTS, LINK_LENGTH, Q_DEFAULT
from navstack.path import PathMemory

CHAIN = jpl_serpentine()
H = 1e-6  # central differences: truncation ~ H^2 |z'''| ~ 1e-12, round-off ~ 1e-16 / H ~ 1e-10


def _kin(q: np.ndarray) -> Kinematics:
    kin = Kinematics(CHAIN)
    kin.update(np.array(q, dtype=np.float64))
    return kin


def _random_q(rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(CHAIN.lower + 0.05, CHAIN.upper - 0.05)


def _check_jacobian(task: Task, q: np.ndarray) -> float:
    """Largest |J - dz/dq| (central differences) over the task's rows at ``q``, relative to max(1, |J|)."""
    T = task.rows(_kin(q))
    fd = np.empty_like(T.J)
    for j in range(CHAIN.n):
        dq = np.zeros(CHAIN.n)
        dq[j] = H
        fd[:, j] = (task.rows(_kin(q + dq)).z - task.rows(_kin(q - dq)).z) / (2 * H)
    return float(np.abs(fd - T.J).max() / max(1.0, np.abs(T.J).max()))


def _moved_path() -> tuple[PathMemory, np.ndarray, np.ndarray]:
    """A path memory from the default backbone, the tip driven 6 cm along a slanted line."""
    backbone = CHAIN.points_and_jacobians(Q_DEFAULT)[0]
    path = PathMemory(backbone, link_length=LINK_LENGTH)
    direction = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    for k in range(1, 31):
        path.advance(backbone[0] + 0.002 * k * direction, 0.05 * direction)
    return path, backbone[0] + 0.06 * direction, 0.05 * direction


# ---------------------------------------------------------------- tip
def test_tip_task_jacobian_matches_finite_differences():
    rng = np.random.default_rng(11)
    task = TipTask(weight=2.0, gain=7.0)
    x_d, xdot_d = np.array([0.3, -0.1, 1.2]), np.array([0.0, 0.05, 0.0])
    task.set_target(x_d, xdot_d)
    for _ in range(5):
        q = _random_q(rng)
        assert _check_jacobian(task, q) <= 1e-7
        T = task.rows(_kin(q))
        np.testing.assert_allclose(T.z, CHAIN.frames(q)[21, :3, 3], atol=1e-15)  # the tip, frame 21
        np.testing.assert_array_equal(T.z_d, x_d)
        np.testing.assert_array_equal(T.zdot_d, xdot_d)
        assert (T.w == 2.0).all() and (T.k == 7.0).all() and T.names == ("tip.x", "tip.y", "tip.z")


# ---------------------------------------------------------------- slither
@pytest.mark.parametrize("form", ["projected", "full"])
def test_slither_task_jacobian_matches_finite_differences(form):
    rng = np.random.default_rng(12)
    path, x_d, xdot_d = _moved_path()
    task = SlitherTask(path, form, weight=1.0, gain=20.0)
    task.set_target(x_d, xdot_d)
    assert task.size == (12 if form == "projected" else 18)
    for _ in range(5):
        assert _check_jacobian(task, _random_q(rng)) <= 1e-7


def test_slither_task_error_vanishes_on_the_path_and_measures_the_offset_across_it():
    path, x_d, xdot_d = _moved_path()
    proj, full = SlitherTask(path, "projected"), SlitherTask(path, "full")
    for t in (proj, full):
        t.x_d = x_d  # same target, without advancing the shared path twice
    kin = _kin(Q_DEFAULT)
    kin.P[1:] = path.pts  # joint points exactly on their desired points
    assert np.abs(proj.rows(kin).e).max() <= 1e-15 and np.abs(full.rows(kin).e).max() <= 1e-15
    offset = np.array([0.0, 0.003, 0.0])
    kin.P[3] += offset  # J3 off its desired point
    e_proj = proj.rows(kin).e.reshape(6, 2)
    e_full = full.rows(kin).e.reshape(6, 3)
    np.testing.assert_allclose(e_full[2], -offset, atol=1e-15)
    u = (path.pts[1] - path.pts[2]) / np.linalg.norm(path.pts[1] - path.pts[2])  # the desired link J3 -> J2
    across = offset - (offset @ u) * u  # projected rows see the offset across the link only
    assert np.linalg.norm(e_proj[2]) == pytest.approx(np.linalg.norm(across), rel=1e-12)
    assert np.abs(np.delete(e_proj, 2, axis=0)).max() <= 1e-15


def test_the_slither_task_owns_its_path_and_follows_reverse_commands():
    path, x_d, xdot_d = _moved_path()
    task = SlitherTask(path)
    end = path.end_arc_length
    back, tangent = path.point_at(end - 0.01)
    task.set_target(back, -0.05 * tangent, reverse=True)
    assert path.end_arc_length == pytest.approx(end - 0.01, abs=1e-12)
    with pytest.raises(ValueError, match="retrace"):
        task.set_target(back + [0.0, 0.0, 0.01], np.zeros(3), reverse=True)
    with pytest.raises(TypeError, match="PathMemory"):
        SlitherTask(object())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="form"):
        SlitherTask(path, "diagonal")


# ---------------------------------------------------------------- posture and limits
def test_posture_task_unit_rows():
    rng = np.random.default_rng(13)
    target = Q_DEFAULT[ARM_JOINTS] + 0.1
    task = PostureTask(ARM_JOINTS, target, weight=0.5, gain=2.0)
    q = _random_q(rng)
    assert _check_jacobian(task, q) <= 1e-9
    T = task.rows(_kin(q))
    np.testing.assert_array_equal(T.J, np.eye(CHAIN.n)[ARM_JOINTS])
    np.testing.assert_array_equal(T.e, target - q[ARM_JOINTS])
    assert T.names == tuple(f"posture.q{j + 1}" for j in ARM_JOINTS) and (T.w == 0.5).all()
    with pytest.raises(ValueError, match="target"):
        task.set_target(target[:3])


def test_limit_task_pushes_back_inside_its_margin_with_a_smooth_weight():
    m = 0.2
    task = JointLimitTask(CHAIN.lower, CHAIN.upper, m, weight=1.0, gain=5.0)
    q = Q_DEFAULT.copy()
    weights = []
    for depth in (0.0, 0.25, 0.5, 1.0, 1.5):
        q[12] = CHAIN.upper[12] - m + depth * m
        q[3] = CHAIN.lower[3] + m - depth * m
        T = task.rows(_kin(q))
        weights.append(T.w[12])
        assert T.w[3] == pytest.approx(T.w[12], abs=1e-12)
        assert T.e[12] == pytest.approx(-depth * m, abs=1e-15) and T.e[3] == pytest.approx(depth * m, abs=1e-15)
        assert _check_jacobian(task, q) <= 1e-9
    np.testing.assert_allclose(weights, [0.0, 0.15625, 0.5, 1.0, 1.0], atol=1e-12)  # 3x^2 - 2x^3, capped
    assert np.count_nonzero(T.w) == 2  # every other joint outside its margin: weight 0
    with pytest.raises(ValueError, match="no free range for joint 9"):
        JointLimitTask(CHAIN.lower, CHAIN.upper, 1.4)  # serpentine range 2.6 rad


@pytest.mark.parametrize("cls", [TipTask, PostureTask, JointLimitTask])
def test_tasks_validate_their_weight_and_gain(cls):
    args = {PostureTask: (ARM_JOINTS, Q_DEFAULT[ARM_JOINTS]), JointLimitTask: (CHAIN.lower, CHAIN.upper, 0.1)}
    with pytest.raises(ValueError, match="weight"):
        cls(*args.get(cls, ()), weight=-1.0)
    with pytest.raises(ValueError, match="gain"):
        cls(*args.get(cls, ()), gain=float("nan"))


# ---------------------------------------------------------------- the solver
class LatheHold(Task):
    """A task written for this test alone (numpy, no compiled kernel): hold the lathe bed at 0.3 m."""

    name = "lathe"

    @property
    def size(self) -> int:
        return 1

    def row_names(self) -> tuple[str, ...]:
        return ("lathe.q1",)

    def fill(self, kin, R, info, r0):
        R[r0] = 0.0
        R[r0, 0] = 1.0
        info[[I_Z, I_ZD, I_ZDOT, I_W, I_K, I_COL], r0] = kin.q[0], 0.3, 0.0, self.weight, self.gain, -1.0


def test_the_solver_stacks_any_tasks_into_equation_4():
    rng = np.random.default_rng(14)
    path, x_d, xdot_d = _moved_path()
    tip, slither = TipTask(), SlitherTask(path)
    tip.set_target(x_d, xdot_d)
    slither.x_d = x_d
    tasks = [tip, slither, LatheHold(weight=0.5, gain=3.0), PostureTask(ARM_JOINTS, Q_DEFAULT[ARM_JOINTS]),
             JointLimitTask(CHAIN.lower, CHAIN.upper, 0.1)]
    wv = rng.uniform(0.05, 1.0, CHAIN.n)
    damping = AdaptiveDamping(0.01, 0.1, 0.05, 1, wv, rows=15)
    solver = TaskSolver(CHAIN, tasks, wv, damping)
    q = _random_q(rng)
    assert solver.solve(q)
    T = solver.stack(q)
    assert T.J.shape == (3 + 12 + 1 + 7 + 20, 20) and T.names[15] == "lathe.q1"
    np.testing.assert_allclose(solver.rate, dls_rate(T.J, T.w, wv, damping.lam2, T.zdot_d, T.k, T.e),
                               rtol=1e-9, atol=1e-12)
    # the conditioning rows are the weighted tip rows and projected slither rows
    Jh = np.sqrt(T.w[:15, None]) * T.J[:15] / np.sqrt(wv)
    assert damping.sigma == pytest.approx(np.linalg.svd(Jh, compute_uv=False).min(), rel=1e-9)
    with pytest.raises(ValueError, match="unique"):
        TaskSolver(CHAIN, [tip, TipTask()], wv, damping)
