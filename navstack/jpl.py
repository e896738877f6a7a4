"""The JPL serpentine robot of the paper's Figure 2, as data.

Figure 2 is a *modified* (Craig) DH table: row ``i`` holds
``alpha_{i-1}, a_{i-1}, d_i, theta_i`` and
``T_{i-1,i} = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``.

The paper lists lengths in centimetres; everything here is in metres and
radians (``CM = 0.01``).  Joint 1 is the prismatic lathe bed (``q[0]`` adds to
``d_1``), joints 2..8 the 7-DOF Robotics Research arm, joints 9..20 the six
pitch/yaw pairs of the serpentine.  Row 21 is the tool frame (the tip).

Joint limits are not given in the paper; the defaults below are documented
choices (see README "Robot model"):

* lathe bed travel: -1.0 .. 2.0 m,
* arm roll joints (2, 4, 6, 8): +-170 deg, arm pitch joints (3, 5, 7): +-120 deg
  (the envelope of a Robotics Research K-1207 class arm),
* serpentine pitch/yaw joints: +-75 deg.
"""

from __future__ import annotations

import numpy as np

from navstack.kinematics import Chain

CM = 0.01
"""Metres per centimetre: Figure 2 is in centimetres."""

PI = np.pi

# ---- Figure 2, rows i = 1..21 --------------------------------------------
# alpha_{i-1} [rad]
ALPHA = np.array(
    [0, PI / 2, PI / 2, PI / 2, PI / 2, PI / 2, PI / 2, PI / 2, -PI / 2, -PI / 2]
    + [PI / 2, -PI / 2] * 5
    + [0.0]  # row 21, tool frame: alpha_20 = 0 (interfaces.md section 1)
)
# a_{i-1} [cm]
A_CM = np.array([0, 0, 12.32, 10.79, 7.94, 7.94, 4.92, 4.92, 0, 0] + [20.0, 0] * 5 + [20.0])
# d_i [cm]
D_CM = np.array([0, 0, 0, 54.6, 0, 54.6, 0, 20.0, 0, 0] + [0] * 11)
# theta_i offset [rad] (a blank theta_2 is 0)
THETA = np.array([0, 0, PI / 2, PI, PI, PI, PI, 0, -PI / 2, 0] + [0] * 11)

N_JOINTS = 20
"""Joints 1..20; the joint vector q has this many entries."""

PRISMATIC = np.zeros(N_JOINTS, dtype=np.bool_)
PRISMATIC[0] = True  # joint 1: the lathe bed

ARM_JOINTS = np.arange(1, 8)
"""0-based indices into q of the arm joints 2..8."""
SERPENTINE_JOINTS = np.arange(8, 20)
"""0-based indices into q of the serpentine joints 9..20 (pitch, yaw pairs)."""

LINK_LENGTH = 20.0 * CM
"""Serpentine link length [m]: consecutive joint points are this far apart."""

TIP_FRAME = 21
JOINT_POINT_FRAMES = np.array([19, 17, 15, 13, 11, 9])
"""DH frames whose origins are the serpentine joint points J1 (nearest the
tip) .. J6 (at the arm's flange)."""
BACKBONE_FRAMES = np.array([21, 19, 17, 15, 13, 11, 9])
"""Tip, J1, ..., J6: the serpentine backbone from the tip back to the flange."""
ARM_FRAMES = np.arange(1, 10)
"""Frames whose consecutive distinct origins bound the arm's capsules."""

DEG = PI / 180.0
LOWER = np.empty(N_JOINTS)
UPPER = np.empty(N_JOINTS)
LOWER[0], UPPER[0] = -1.0, 2.0
for _j in ARM_JOINTS:  # joint number = index + 1; roll joints are 2, 4, 6, 8
    _lim = 170 * DEG if (_j + 1) % 2 == 0 else 120 * DEG
    LOWER[_j], UPPER[_j] = -_lim, _lim
LOWER[SERPENTINE_JOINTS], UPPER[SERPENTINE_JOINTS] = -75 * DEG, 75 * DEG

Q_DEFAULT = np.zeros(N_JOINTS)
Q_DEFAULT[[3, 4, 6]] = [-PI / 2, PI / 3, PI / 6]
"""Default posture: elbow bent 60 deg, wrist 30 deg, serpentine straight and
pointing along the lathe axis z0 (so the lathe bed does the insertion)."""

SERPENTINE_RADIUS = 0.025
ARM_RADIUS = 0.06
MIN_ROBOT_RADIUS = 0.01
"""Metres: the smallest capsule radius of a link (world files' ``serpentine_radius`` / ``arm_radius``, URDF)."""
MAX_ROBOT_RADIUS = 0.5
"""Metres: the largest capsule radius of a link."""


def jpl_serpentine() -> Chain:
    """The 20-DOF JPL robot of Figure 2 (lathe bed + RRC arm + serpentine).

    ``jpl_serpentine().frames(q)`` returns the (22, 4, 4) transforms of DH
    frames 0..21 (21 = tip) in the base frame, in metres.
    """
    return Chain(
        alpha=ALPHA,
        a=A_CM * CM,
        d=D_CM * CM,
        theta=THETA,
        prismatic=PRISMATIC,
        lower=LOWER,
        upper=UPPER,
        q_default=Q_DEFAULT,
        point_frames=BACKBONE_FRAMES,
        name="jpl-serpentine",
    )
