"""The robot as a URDF document, for other tools (PyBullet, Pinocchio, ROS, MoveIt, Drake ...).

:func:`chain_to_urdf` writes a modified-DH :class:`~navstack.kinematics.Chain` (for the JPL robot:
``jpl_serpentine().to_urdf()``) as URDF 1.0 XML.  Units: metres, radians, kilograms, kg m^2.

Kinematics.  Link ``dh<k>`` is DH frame ``k`` (``dh0`` is the base, the root; ``dh21`` is the tip of
the JPL robot).  Joint ``joint<k>`` (k = 1..n) connects ``dh<k-1>`` to ``dh<k>``; its ``<origin>`` is
the table row at joint value zero, ``Rx(alpha_{k-1}) Tx(a_{k-1}) Rz(theta_k) Tz(d_k)``, and it moves
along (prismatic) or about (revolute) its own z axis, which reproduces ``Rz(theta_k) Tz(d_k + q)`` and
``Rz(theta_k + q) Tz(d_k)`` exactly (``Rz`` and ``Tz`` commute).  Rows past the last joint (the tool
frame) are ``fixed`` joints.  The ``<origin rpy>`` angles are URDF's fixed-axis roll X, pitch Y, yaw Z,
printed with 17 significant digits so that a reader rebuilds ``frames(q)`` to rounding error.  Joint
limits are the chain's ``lower``/``upper``; URDF requires an effort and a velocity limit, which navstack
does not model: :class:`UrdfOptions` documents the values written.

Collision geometry (interfaces.md section 1).  Each link ``dh<k>`` carries a capsule from its own
origin to the origin of ``dh<k+1>`` (skipped where the two coincide), radius ``arm_radius`` for frames
below ``first_serpentine_frame`` and ``serpentine_radius`` from it on.  URDF 1.0 has no capsule, so a
capsule is written as three ``<collision>`` elements, a cylinder between the two end points and a sphere
at each end: their union is exactly the capsule (the set of points within the radius of the segment),
and cylinders and spheres are understood by every URDF reader, whereas PyBullet's ``<capsule>``
extension is not (urdfdom, and with it Pinocchio and ROS, rejects it or drops it).  The visual geometry
is the same three shapes.

Inertia.  As :mod:`navstack.sim.body` builds the PyBullet body: every link ``dh1 .. dh<rows>`` is a
lumped mass at its frame origin (``<inertial>`` origin zero) with a diagonal, isotropic inertia; the
base ``dh0`` has mass 0 (it is fixed to the world).

Loading it in PyBullet: ``loadURDF(path, useFixedBase=True, flags=URDF_USE_INERTIA_FROM_FILE |
URDF_USE_IMPLICIT_CYLINDER)``.  Without the first flag PyBullet replaces the inertias by its own estimate
from the collision shapes (2.7e-6 kg m^2 instead of 0.05 for an arm link, measured); without the second
it turns every cylinder into a convex mesh (distances off by up to 4.8 mm, measured), where the flag gives
an exact ``btCylinderShape`` (distances within 2e-5 m of navstack's own capsules).

This module imports only numpy, scipy and the standard library (the core's isolation rules allow it).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from navstack.jpl import MAX_ROBOT_RADIUS, MIN_ROBOT_RADIUS
from navstack.validate import in_range, integer

if TYPE_CHECKING:
    from navstack.kinematics import Chain

ARM_LINK_MASS = 4.0
"""kg per arm link (frames 1..8), as :data:`navstack.sim.body.ARM_LINK_MASS`."""
SERPENTINE_LINK_MASS = 0.3
"""kg per serpentine link (frames 9..21), as :data:`navstack.sim.body.SERPENTINE_LINK_MASS`."""
ARM_LINK_INERTIA = 0.05
"""kg m^2, each principal moment of an arm link, as :data:`navstack.sim.body.ARM_LINK_INERTIA`."""
SERPENTINE_LINK_INERTIA = 0.002
"""kg m^2, each principal moment of a serpentine link, as :data:`navstack.sim.body.SERPENTINE_LINK_INERTIA`."""


MAX_URDF_VALUE = 1.0e6
"""The largest mass [kg], inertia [kg m^2], effort [N, N m] or velocity limit a URDF is written with."""


@dataclass(frozen=True)
class UrdfOptions:
    """What the URDF holds beyond the DH table and the joint limits.

    Attributes:
        serpentine_radius: capsule radius of the serpentine links [m] (interfaces.md default 0.025).
        arm_radius: capsule radius of the arm links [m] (default 0.06).
        first_serpentine_frame: first DH frame that is a serpentine link (9 for the JPL robot).
        arm_mass, serpentine_mass: lumped link masses [kg].
        arm_inertia, serpentine_inertia: each principal moment of inertia of a link [kg m^2].
        effort_prismatic: effort limit written for prismatic joints [N] (navstack does not model it).
        effort_revolute: effort limit written for revolute joints [N m] (not modelled).
        velocity: velocity limit written for every joint [m/s or rad/s] (not modelled).
        name: the ``<robot name>``; the chain's name when ``None``.
    """

    serpentine_radius: float = 0.025
    arm_radius: float = 0.06
    first_serpentine_frame: int = 9
    arm_mass: float = ARM_LINK_MASS
    serpentine_mass: float = SERPENTINE_LINK_MASS
    arm_inertia: float = ARM_LINK_INERTIA
    serpentine_inertia: float = SERPENTINE_LINK_INERTIA
    effort_prismatic: float = 1000.0
    effort_revolute: float = 300.0
    velocity: float = 1.0
    name: str | None = None

    def __post_init__(self) -> None:
        in_range(self, "serpentine_radius", "arm_radius", lo=MIN_ROBOT_RADIUS, hi=MAX_ROBOT_RADIUS,
                 what=f"a number from {MIN_ROBOT_RADIUS:g} to {MAX_ROBOT_RADIUS:g} m (as in world files)")
        in_range(self, "arm_mass", "serpentine_mass", "arm_inertia", "serpentine_inertia", "effort_prismatic",
                 "effort_revolute", "velocity", lo=0.0, hi=MAX_URDF_VALUE, lo_open=True)
        integer(self, "first_serpentine_frame")
        if self.name is not None and not isinstance(self.name, str):
            raise ValueError(f"UrdfOptions.name must be a string or None, got {self.name!r}")


def _num(x: float) -> str:
    """A float as URDF text that reads back to the same double (17 significant digits, no ``-0``)."""
    x = float(x)
    if x == 0.0:
        return "0"
    return repr(x)


def _vec(v: NDArray[np.float64] | list[float]) -> str:
    return " ".join(_num(x) for x in v)


def _row_transform(alpha: float, a: float, d: float, theta: float) -> NDArray[np.float64]:
    """``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` as a 4x4 homogeneous transform (m, rad)."""
    ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(theta), math.sin(theta)
    return np.array([
        [ct, -st, 0.0, a],
        [st * ca, ct * ca, -sa, -sa * d],
        [st * sa, ct * sa, ca, ca * d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def _origin(T: NDArray[np.float64]) -> str:
    """``<origin>`` of a rigid transform: URDF rpy is roll X, pitch Y, yaw Z about the fixed axes."""
    with warnings.catch_warnings():  # at pitch +-pi/2 the split of roll and yaw is arbitrary, still exact
        warnings.simplefilter("ignore", UserWarning)
        rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz")
    return f'<origin xyz="{_vec(T[:3, 3])}" rpy="{_vec(rpy)}"/>'


def _capsule(seg: NDArray[np.float64], radius: float, tag: str, material: str = "") -> list[str]:
    """A capsule from the link origin to ``seg`` (link frame, m) as cylinder + two spheres."""
    length = float(np.linalg.norm(seg))
    u = seg / length
    rot, _ = Rotation.align_vectors([u], [[0.0, 0.0, 1.0]])  # cylinder axis: local z
    T = np.eye(4)
    T[:3, :3] = rot.as_matrix()
    T[:3, 3] = seg / 2.0
    out = []
    shapes = [
        (T, f'<cylinder radius="{_num(radius)}" length="{_num(length)}"/>'),
        (np.eye(4), f'<sphere radius="{_num(radius)}"/>'),
        (np.block([[np.eye(3), seg.reshape(3, 1)], [np.zeros((1, 3)), np.ones((1, 1))]]),
         f'<sphere radius="{_num(radius)}"/>'),
    ]
    for pose, geom in shapes:
        out.append(f"    <{tag}>")
        out.append(f"      {_origin(pose)}")
        out.append(f"      <geometry>{geom}</geometry>")
        if material:
            out.append(f'      <material name="{material}"/>')
        out.append(f"    </{tag}>")
    return out


def chain_to_urdf(chain: Chain, options: UrdfOptions | None = None) -> str:
    """The URDF document (a string) of ``chain`` with the geometry and inertia of ``options``.

    See the module docstring for the conventions.  Raises ``ValueError`` on invalid options.
    """
    opt = options or UrdfOptions()
    rows = len(chain.alpha)
    name = opt.name if opt.name is not None else chain.name
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- written by navstack (navstack.urdf): modified-DH frames dh0..dh{rows}, metres/radians/kg -->",
        f"<robot name={quoteattr(name)}>",
        '  <material name="arm"><color rgba="0.85 0.55 0.15 1"/></material>',
        '  <material name="serpentine"><color rgba="0.2 0.6 0.25 1"/></material>',
        '  <link name="dh0">',  # the fixed base: mass 0 (static in PyBullet, no warning about missing inertia)
        '    <inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="0"/>'
        '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>',
        "  </link>",
    ]
    for k in range(1, rows + 1):  # link dh<k>, joint joint<k> from dh<k-1>
        serp = k >= opt.first_serpentine_frame
        mass = opt.serpentine_mass if serp else opt.arm_mass
        inertia = opt.serpentine_inertia if serp else opt.arm_inertia
        radius = opt.serpentine_radius if serp else opt.arm_radius
        lines.append(f'  <link name="dh{k}">')
        lines.append("    <inertial>")
        lines.append('      <origin xyz="0 0 0" rpy="0 0 0"/>')
        lines.append(f'      <mass value="{_num(mass)}"/>')
        i = _num(inertia)
        lines.append(f'      <inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/>')
        lines.append("    </inertial>")
        if k < rows:
            seg = _row_transform(chain.alpha[k], chain.a[k], chain.d[k], chain.theta[k])[:3, 3]
            if np.linalg.norm(seg) > 1e-9:
                material = "serpentine" if serp else "arm"
                lines += _capsule(seg, radius, "visual", material)
                lines += _capsule(seg, radius, "collision")
        lines.append("  </link>")
        T = _row_transform(chain.alpha[k - 1], chain.a[k - 1], chain.d[k - 1], chain.theta[k - 1])
        j = k - 1
        kind = "fixed" if j >= chain.n else ("prismatic" if chain.prismatic[j] else "revolute")
        lines.append(f'  <joint name="joint{k}" type="{kind}">')
        lines.append(f'    <parent link="dh{k - 1}"/>')
        lines.append(f'    <child link="dh{k}"/>')
        lines.append(f"    {_origin(T)}")
        if kind != "fixed":
            effort = opt.effort_prismatic if kind == "prismatic" else opt.effort_revolute
            lines.append('    <axis xyz="0 0 1"/>')
            lines.append(f'    <limit lower="{_num(chain.lower[j])}" upper="{_num(chain.upper[j])}" '
                         f'effort="{_num(effort)}" velocity="{_num(opt.velocity)}"/>')
        lines.append("  </joint>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def write_urdf(chain: Chain, path: str | os.PathLike[str], options: UrdfOptions | None = None) -> Path:
    """Write :func:`chain_to_urdf` to ``path`` (UTF-8) and return the path."""
    out = Path(path)
    out.write_text(chain_to_urdf(chain, options), encoding="utf-8")
    return out
