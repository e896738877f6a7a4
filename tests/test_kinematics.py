"""Forward kinematics and point Jacobians of the JPL robot (Figure 2).

References: central finite differences of our own FK (every Jacobian), a
direct transcription of the modified-DH product (independent of the numba
kernel), and the geometry the paper states (link lengths, joint points).
"""

from __future__ import annotations

import numpy as np
import pytest

import navstack
from navstack import jpl

ROBOT = navstack.jpl_serpentine()
RNG = np.random.default_rng(20261122)


def _configs(n: int) -> list[np.ndarray]:
    """Random configurations within the limits plus near-singular ones."""
    qs = [RNG.uniform(ROBOT.lower, ROBOT.upper) for _ in range(n - 4)]
    straight = ROBOT.q_default.copy()  # serpentine straight
    stretched = np.zeros(20)  # arm at full stretch, serpentine straight: all in one line
    nearly = stretched + 1e-7 * RNG.standard_normal(20)
    folded = ROBOT.q_default.copy()
    folded[8:] = np.radians(75.0)  # every serpentine joint at its limit
    return qs + [straight, stretched, nearly, folded]


CONFIGS = _configs(100)


def _dh_reference(q: np.ndarray) -> np.ndarray:
    """Plain numpy transcription of T_{i-1,i} = Rx(alpha) Tx(a) Rz(theta) Tz(d)."""

    def rx(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])

    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])

    def tx(a):
        m = np.eye(4)
        m[0, 3] = a
        return m

    def tz(d):
        m = np.eye(4)
        m[2, 3] = d
        return m

    out = [np.eye(4)]
    for i in range(21):
        theta = jpl.THETA[i] + (q[i] if 0 < i < 20 else 0.0)
        d = jpl.D_CM[i] * 0.01 + (q[0] if i == 0 else 0.0)
        out.append(out[-1] @ rx(jpl.ALPHA[i]) @ tx(jpl.A_CM[i] * 0.01) @ rz(theta) @ tz(d))
    return np.array(out)


def test_frames_shape_and_reference():
    for q in CONFIGS[:30]:
        F = ROBOT.frames(q)
        assert F.shape == (22, 4, 4)
        np.testing.assert_allclose(F, _dh_reference(q), atol=1e-12)


def test_serpentine_joint_points_one_link_apart():
    for q in CONFIGS:
        F = ROBOT.frames(q)
        pts = F[jpl.BACKBONE_FRAMES, :3, 3]  # tip, J1..J6
        gaps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        np.testing.assert_allclose(gaps, jpl.LINK_LENGTH, atol=1e-12)


def test_default_posture_points_serpentine_along_lathe_axis():
    F = ROBOT.frames(ROBOT.q_default)
    u = F[21, :3, 3] - F[9, :3, 3]
    np.testing.assert_allclose(u / np.linalg.norm(u), [0, 0, 1], atol=1e-12)
    assert np.all(ROBOT.q_default >= ROBOT.lower) and np.all(ROBOT.q_default <= ROBOT.upper)


def _fd_jacobian(frame: int, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    J = np.empty((3, 20))
    for j in range(20):
        dq = np.zeros(20)
        dq[j] = h
        J[:, j] = (ROBOT.frames(q + dq)[frame, :3, 3] - ROBOT.frames(q - dq)[frame, :3, 3]) / (2 * h)
    return J


def test_point_jacobians_match_central_differences():
    worst = 0.0
    for q in CONFIGS:
        pts, jac = ROBOT.points_and_jacobians(q)
        for m, frame in enumerate(jpl.BACKBONE_FRAMES):
            np.testing.assert_allclose(pts[m], ROBOT.frames(q)[frame, :3, 3], atol=1e-15)
            err = np.abs(jac[m] - _fd_jacobian(frame, q)).max()
            worst = max(worst, err)
            assert err < 1e-8, f"frame {frame}: Jacobian differs from central differences by {err:g}"
    print(f"worst |J - J_fd| over {len(CONFIGS)} configs x 7 points: {worst:.2e}")


def test_point_jacobian_any_frame():
    q = CONFIGS[3]
    for frame in (1, 5, 8, 12):
        np.testing.assert_allclose(ROBOT.point_jacobian(q, frame), _fd_jacobian(frame, q), atol=1e-8)
    with pytest.raises(ValueError, match="frame"):
        ROBOT.point_jacobian(q, 22)


def test_point_jacobian_buffer_mode_is_overwritten_not_shared_with_copies():
    a_pts, a_jac = ROBOT.points_and_jacobians(CONFIGS[0])
    b_pts, b_jac = ROBOT.points_and_jacobians(CONFIGS[1])
    assert not np.allclose(a_jac, b_jac)
    np.testing.assert_allclose(a_jac, ROBOT.points_and_jacobians(CONFIGS[0])[1])


@pytest.mark.parametrize(
    "q, message",
    [
        (np.zeros(19), "20 joint values"),
        (np.zeros((20, 1)), "20 joint values"),
        (np.r_[np.zeros(5), np.nan, np.zeros(14)], r"q\[5\] \(joint 6\) is nan"),
        (np.r_[np.zeros(19), np.inf], r"q\[19\] \(joint 20\) is inf"),
        (["0"] * 20, "must hold real numbers, got <U1"),  # strings, booleans and complex values
        ([True] * 20, "must hold real numbers, got bool"),  # converted silently before
        (np.zeros(20, dtype=complex), "must hold real numbers, got complex128"),
        ([0.0] * 19 + [[0.0, 1.0]], "20 joint values, got a ragged sequence"),  # numpy's own message before
    ],
)
def test_bad_joint_vectors_raise(q, message):
    with pytest.raises(ValueError, match=message):
        ROBOT.frames(q)
    with pytest.raises(ValueError, match=message):
        ROBOT.points_and_jacobians(q)


@pytest.mark.parametrize("q, message", [(object(), "got object"), ([None] * 20, "got entries that are not real"),
                                        ([None] + [0.0] * 19, "got entries that are not real"),
                                        ([True] * 19 + [None], "got entries that are not real"),
                                        (["0"] * 19 + [None], "got entries that are not real")])
def test_joint_vectors_of_objects_are_a_type_error(q, message):
    """A World passed where q0 goes must stay a TypeError naming it (tests/test_isolation.py)."""
    with pytest.raises(TypeError, match=message):
        ROBOT.frames(q)


def test_real_numbers_numpy_keeps_as_objects_are_joint_values():
    """An object array of floats, or an int too large for int64 among them, was called 'not numbers'."""
    np.testing.assert_array_equal(ROBOT.frames(np.zeros(20, dtype=object)), ROBOT.frames(np.zeros(20)))
    q = [0.0] * 20
    q[5] = 10**30  # a finite real number (far outside the limits: frames does not check limits)
    assert np.isfinite(ROBOT.frames(q)[1]).all()


def test_table_units_are_metres():
    assert ROBOT.a[2] == pytest.approx(0.1232)
    assert ROBOT.d[3] == pytest.approx(0.546)
    assert ROBOT.a[20] == pytest.approx(0.20)  # the tool frame: a_20 = 20 cm
    assert ROBOT.n == 20 and ROBOT.prismatic[0] and not ROBOT.prismatic[1:].any()


@pytest.mark.parametrize("frame", [-1, 22])
def test_a_point_jacobian_of_a_frame_outside_the_chain_is_refused(frame):
    """Frames 0..21 exist (21 the tip); -1 would otherwise index the tip from the end, without a word."""
    q = ROBOT.q_default
    with pytest.raises(ValueError, match=r"frame must be in 0\.\.21, got " + str(frame)):
        ROBOT.point_jacobian(q, frame)
    np.testing.assert_array_equal(ROBOT.point_jacobian(q, 0), np.zeros((3, 20)))  # the base frame: fixed
    assert ROBOT.point_jacobian(q, 21).shape == (3, 20)


def test_a_dh_table_with_fewer_rows_than_joints_is_refused():
    """One joint more than rows: refused; as many joints as rows (no tool row) is a chain."""
    rows = dict(alpha=[0.0, 0.0], a=[0.0, 0.1], d=[0.0, 0.0], theta=[0.0, 0.0], point_frames=[2])
    with pytest.raises(ValueError, match="more joints than DH rows"):
        navstack.kinematics.Chain(**rows, prismatic=[False] * 3, lower=[-1.0] * 3, upper=[1.0] * 3,
                                  q_default=[0.0] * 3)
    chain = navstack.kinematics.Chain(**rows, prismatic=[False] * 2, lower=[-1.0] * 2, upper=[1.0] * 2,
                                      q_default=[0.0] * 2)
    np.testing.assert_allclose(chain.frames([np.pi / 2, 0.0])[2, :3, 3], [0.0, 0.1, 0.0], atol=1e-15)
