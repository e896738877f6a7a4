"""Forward kinematics and point Jacobians of a modified-DH serial chain.

Pure numpy data, compiled with numba: a control step calls these once, so
they are written as loops over the chain (a prefix product of 4x4
transforms) rather than as many small numpy calls.

Conventions (interfaces.md section 1): row ``i`` (1-based) of the table holds
``alpha_{i-1}, a_{i-1}, d_i, theta_i`` and
``T_{i-1,i} = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``.  Joint ``i``
(``q[i-1]``) adds to ``d_i`` if prismatic, else to ``theta_i``.  Rows past the
last joint are fixed (the tool frame).  Lengths in metres, angles in radians.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray


@numba.njit(cache=True)
def frames_into(alpha, a, d, theta, prismatic, q, out):  # pragma: no cover - jitted
    """Write the transforms of frames 0..len(alpha) (base frame) into ``out``."""
    n_rows = alpha.shape[0]
    n = q.shape[0]
    for r in range(4):
        for c in range(4):
            out[0, r, c] = 1.0 if r == c else 0.0
    for i in range(n_rows):
        th = theta[i]
        dd = d[i]
        if i < n:
            if prismatic[i]:
                dd += q[i]
            else:
                th += q[i]
        ca = np.cos(alpha[i])
        sa = np.sin(alpha[i])
        ct = np.cos(th)
        st = np.sin(th)
        # T = Rx(alpha) Tx(a) Rz(theta) Tz(d)
        t00, t01, t02, t03 = ct, -st, 0.0, a[i]
        t10, t11, t12, t13 = st * ca, ct * ca, -sa, -sa * dd
        t20, t21, t22, t23 = st * sa, ct * sa, ca, ca * dd
        P = out[i]
        Q = out[i + 1]
        for r in range(3):
            p0 = P[r, 0]
            p1 = P[r, 1]
            p2 = P[r, 2]
            Q[r, 0] = p0 * t00 + p1 * t10 + p2 * t20
            Q[r, 1] = p0 * t01 + p1 * t11 + p2 * t21
            Q[r, 2] = p0 * t02 + p1 * t12 + p2 * t22
            Q[r, 3] = p0 * t03 + p1 * t13 + p2 * t23 + P[r, 3]
        Q[3, 0] = 0.0
        Q[3, 1] = 0.0
        Q[3, 2] = 0.0
        Q[3, 3] = 1.0


@numba.njit(cache=True)
def point_jacobians_into(F, prismatic, point_frames, out):  # pragma: no cover
    """Position Jacobians (3 x n) of the origins of ``point_frames``.

    Joint ``j`` (0-based) moves along / about the z axis of frame ``j + 1``
    through that frame's origin; it moves the origin of frame ``f`` only if
    ``j + 1 <= f``.
    """
    n = prismatic.shape[0]
    for m in range(point_frames.shape[0]):
        f = point_frames[m]
        px = F[f, 0, 3]
        py = F[f, 1, 3]
        pz = F[f, 2, 3]
        for j in range(n):
            fr = j + 1
            if fr > f:
                out[m, 0, j] = 0.0
                out[m, 1, j] = 0.0
                out[m, 2, j] = 0.0
                continue
            zx = F[fr, 0, 2]
            zy = F[fr, 1, 2]
            zz = F[fr, 2, 2]
            if prismatic[j]:
                out[m, 0, j] = zx
                out[m, 1, j] = zy
                out[m, 2, j] = zz
            else:
                rx = px - F[fr, 0, 3]
                ry = py - F[fr, 1, 3]
                rz = pz - F[fr, 2, 3]
                out[m, 0, j] = zy * rz - zz * ry
                out[m, 1, j] = zz * rx - zx * rz
                out[m, 2, j] = zx * ry - zy * rx


def check_q(q: ArrayLike, n: int, name: str = "q") -> NDArray[np.float64]:
    """Return ``q`` as a float64 vector of length ``n``, or raise ``ValueError`` (``TypeError`` for objects
    that are not numbers at all).

    The message names the problem: values that are not real numbers (strings, booleans, complex), a wrong
    length, or the first non-finite entry (with its 1-based joint number).
    """
    try:
        raw = np.asarray(q)
    except ValueError:  # a ragged sequence
        raise ValueError(f"{name} must be a vector of {n} joint values, got a ragged sequence") from None
    if raw.dtype.kind == "O":  # Python objects: real numbers numpy keeps as objects (10**30), or not numbers
        if raw.ndim == 0 or not all(isinstance(x, (int, float, np.integer, np.floating))
                                    and not isinstance(x, (bool, np.bool_)) for x in raw.ravel()):
            what = type(q).__name__ if raw.ndim == 0 else "entries that are not real numbers"
            raise TypeError(f"{name} must hold real numbers, got {what}")  # a World, None, a string among them
        raw = raw.astype(np.float64)
    if raw.dtype.kind not in "fiu":  # "0" strings, True, 1+0j converted silently before
        raise ValueError(f"{name} must hold real numbers, got {raw.dtype} values")
    arr = raw.astype(np.float64, copy=False)
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a vector of {n} joint values, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name}[{j}] (joint {j + 1}) is {arr[j]}: joint values must be finite")
    return arr


@dataclass(frozen=True)
class Chain:
    """A serial chain described by a modified (Craig) DH table.

    Attributes are per table row (``alpha``, ``a``, ``d``, ``theta``: one per
    frame 1..N, the rows past ``len(prismatic)`` being fixed tool rows) and
    per joint (``prismatic``, ``lower``, ``upper``, ``q_default``).
    ``point_frames`` are the frames whose origins get Jacobians from
    :meth:`points_and_jacobians` (for the JPL robot: tip, J1..J6).
    """

    alpha: NDArray[np.float64]
    a: NDArray[np.float64]
    d: NDArray[np.float64]
    theta: NDArray[np.float64]
    prismatic: NDArray[np.bool_]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    q_default: NDArray[np.float64]
    point_frames: NDArray[np.int64]
    name: str = "chain"
    _frames_buf: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _jac_buf: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rows = len(self.alpha)
        for key in ("a", "d", "theta"):
            if len(getattr(self, key)) != rows:
                raise ValueError(f"DH column {key!r} has {len(getattr(self, key))} rows, expected {rows}")
        if len(self.prismatic) > rows:
            raise ValueError("more joints than DH rows")
        cast = {
            "alpha": np.float64,
            "a": np.float64,
            "d": np.float64,
            "theta": np.float64,
            "prismatic": np.bool_,
            "lower": np.float64,
            "upper": np.float64,
            "q_default": np.float64,
            "point_frames": np.int64,
        }
        for key, dtype in cast.items():
            arr = np.ascontiguousarray(getattr(self, key), dtype=dtype)
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        object.__setattr__(self, "_frames_buf", np.empty((rows + 1, 4, 4)))
        object.__setattr__(self, "_jac_buf", np.empty((len(self.point_frames), 3, self.n)))

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.prismatic)

    @property
    def n_frames(self) -> int:
        """Number of frames, base frame 0 included."""
        return len(self.alpha) + 1

    def check(self, q: ArrayLike) -> NDArray[np.float64]:
        """Validate a joint vector (length, finiteness); see :func:`check_q`."""
        return check_q(q, self.n)

    def frames(self, q: ArrayLike) -> NDArray[np.float64]:
        """Transforms of all frames in the base frame, shape (n_frames, 4, 4).

        Returns a new array; ``q`` is validated (``ValueError`` on a wrong
        length or a non-finite value).
        """
        out = np.empty((self.n_frames, 4, 4))
        frames_into(self.alpha, self.a, self.d, self.theta, self.prismatic, self.check(q), out)
        return out

    def points_and_jacobians(
        self, q: ArrayLike, *, copy: bool = True
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Origins of ``point_frames`` (k, 3) [m] and their Jacobians (k, 3, n).

        Jacobian columns are in m/m for the prismatic joint and m/rad for the
        revolute ones.  With ``copy=False`` the returned arrays are internal
        buffers overwritten by the next call (for the control loop).
        """
        F = self._frames_buf
        frames_into(self.alpha, self.a, self.d, self.theta, self.prismatic, self.check(q), F)
        point_jacobians_into(F, self.prismatic, self.point_frames, self._jac_buf)
        pts = F[self.point_frames, :3, 3]
        jac = self._jac_buf
        return (pts, jac.copy()) if copy else (pts, jac)

    def point_jacobian(self, q: ArrayLike, frame: int) -> NDArray[np.float64]:
        """Position Jacobian (3, n) of the origin of any one ``frame``."""
        if not 0 <= frame < self.n_frames:
            raise ValueError(f"frame must be in 0..{self.n_frames - 1}, got {frame}")
        F = self.frames(q)
        out = np.empty((1, 3, self.n))
        point_jacobians_into(F, self.prismatic, np.array([frame], dtype=np.int64), out)
        return out[0]

    def clip(self, q: ArrayLike) -> NDArray[np.float64]:
        """``q`` clipped into the joint limits."""
        return np.clip(np.asarray(q, dtype=np.float64), self.lower, self.upper)

    def to_urdf(self, options=None) -> str:
        """This chain as a URDF document (a string): links ``dh0..dh<rows>``, joint limits, capsule
        collision geometry (cylinder + two spheres each), lumped masses; see :mod:`navstack.urdf`.

        ``options`` is a :class:`navstack.urdf.UrdfOptions` (radii [m], masses [kg], inertias [kg m^2]).
        """
        from navstack.urdf import chain_to_urdf

        return chain_to_urdf(self, options)
