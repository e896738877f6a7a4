"""Figure 2 of the paper, transcribed by hand, against navstack's robot model.

The table below is copied from the paper's Figure 2 ("DH Parameters for Serpentine Robot",
shared/paper/000_be12d60415349636.txt), cell by cell in the paper's own units and notation: lengths in
centimetres, angles as printed (multiples of pi), converted here to degrees and then to radians. It is
*not* derived from ``navstack/jpl.py``: both the kernel's arrays and the Pinocchio reference are built from
jpl.py, so only a separate transcription can catch a mistyped cell.

Two cells need reading (interfaces.md section 1 settles both): theta_2 is blank in the figure (0), and the
alpha cell of row 21 (the tool frame) comes out of the paper's text as "θ", a misread 0 (alpha_20 = 0).
Joint types from the paper's text: the mobile platform (joint 1) translates, every other joint rotates.
"""

from __future__ import annotations

import numpy as np
import pytest

from navstack import jpl
from navstack.jpl import jpl_serpentine

# Figure 2, as printed: one string per cell, columns i = 1..10 then 11..21.
FIGURE_2 = {
    "i": list(range(1, 22)),
    "alpha_{i-1}": ["0", "π/2", "π/2", "π/2", "π/2", "π/2", "π/2", "π/2", "-π/2", "-π/2",
                    "π/2", "-π/2", "π/2", "-π/2", "π/2", "-π/2", "π/2", "-π/2", "π/2", "-π/2", "0"],
    "a_{i-1}": ["0", "0", "12.32", "10.79", "7.94", "7.94", "4.92", "4.92", "0", "0",
                "20.0", "0", "20.0", "0", "20.0", "0", "20.0", "0", "20.0", "0", "20.0"],
    "d_i": ["0", "0", "0", "54.6", "0", "54.6", "0", "20.0", "0", "0",
            "0", "0", "0", "0", "0", "0", "0", "0", "0", "0", "0"],
    "theta_i": ["0", "", "π/2", "π", "π", "π", "π", "0", "-π/2", "0",
                "0", "0", "0", "0", "0", "0", "0", "0", "0", "0", "0"],
}
DEGREES = {"0": 0.0, "": 0.0, "π/2": 90.0, "-π/2": -90.0, "π": 180.0}
"""The printed angle notations, in degrees (a blank theta is 0)."""


def _degrees(cells: list[str]) -> np.ndarray:
    return np.array([DEGREES[c] for c in cells])


def _cm(cells: list[str]) -> np.ndarray:
    return np.array([float(c) for c in cells])


ALPHA_DEG = _degrees(FIGURE_2["alpha_{i-1}"])
A_CM = _cm(FIGURE_2["a_{i-1}"])
D_CM = _cm(FIGURE_2["d_i"])
THETA_DEG = _degrees(FIGURE_2["theta_i"])
PRISMATIC = [True] + [False] * 19  # joint 1 is the lathe-bed platform's translation


def test_the_transcription_is_complete():
    assert all(len(col) == 21 for col in FIGURE_2.values())
    assert FIGURE_2["i"] == list(range(1, 22))


@pytest.mark.parametrize("row", range(1, 22))
def test_every_row_matches_the_model(row):
    k = row - 1
    chain = jpl_serpentine()
    assert chain.alpha[k] == pytest.approx(np.radians(ALPHA_DEG[k]), abs=1e-15), f"alpha_{row - 1}"
    assert chain.a[k] == pytest.approx(A_CM[k] / 100.0, abs=1e-15), f"a_{row - 1} [m]"
    assert chain.d[k] == pytest.approx(D_CM[k] / 100.0, abs=1e-15), f"d_{row} [m]"
    assert chain.theta[k] == pytest.approx(np.radians(THETA_DEG[k]), abs=1e-15), f"theta_{row}"
    # the module's own arrays in the paper's units say the same
    assert np.degrees(jpl.ALPHA[k]) == pytest.approx(ALPHA_DEG[k], abs=1e-12)
    assert jpl.A_CM[k] == pytest.approx(A_CM[k], abs=1e-12) and jpl.D_CM[k] == pytest.approx(D_CM[k], abs=1e-12)
    assert np.degrees(jpl.THETA[k]) == pytest.approx(THETA_DEG[k], abs=1e-12)


def test_joint_types_and_the_tool_row():
    chain = jpl_serpentine()
    assert chain.n == 20 and len(chain.alpha) == len(chain.a) == len(chain.d) == len(chain.theta) == 21
    assert chain.prismatic.tolist() == PRISMATIC
    # row 21 is the tool frame: no joint, 20 cm beyond the last serpentine joint, no twist or offset
    assert (ALPHA_DEG[20], A_CM[20], D_CM[20], THETA_DEG[20]) == (0.0, 20.0, 0.0, 0.0)
    assert (chain.alpha[20], chain.a[20], chain.d[20], chain.theta[20]) == (0.0, 0.2, 0.0, 0.0)
    assert jpl.TIP_FRAME == 21


def _fk_from_the_transcription(q: np.ndarray) -> np.ndarray:
    """Frames 0..21 by the modified-DH product T = Rx(alpha) Tx(a) Rz(theta) Tz(d) of the transcribed table."""

    def transform(alpha, a, theta, d):
        ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
        return np.array([[ct, -st, 0.0, a],
                         [st * ca, ct * ca, -sa, -sa * d],
                         [st * sa, ct * sa, ca, ca * d],
                         [0.0, 0.0, 0.0, 1.0]])

    out = [np.eye(4)]
    for k in range(21):
        theta = np.radians(THETA_DEG[k])
        d = D_CM[k] / 100.0
        if k < 20:
            if PRISMATIC[k]:
                d += q[k]
            else:
                theta += q[k]
        out.append(out[-1] @ transform(np.radians(ALPHA_DEG[k]), A_CM[k] / 100.0, theta, d))
    return np.array(out)


def test_forward_kinematics_of_the_transcribed_table():
    chain = jpl_serpentine()
    rng = np.random.default_rng(2)
    for q in [np.zeros(20), chain.q_default, *rng.uniform(chain.lower, chain.upper, size=(20, 20))]:
        np.testing.assert_allclose(chain.frames(q), _fk_from_the_transcription(q), atol=1e-12)
