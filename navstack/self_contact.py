"""Self-contact: the robot's own capsules against each other, measured every control step of a trial.

The robot's collision shape is one capsule per DH frame k whose origin differs from frame k + 1's (interfaces.md
section 1; :meth:`navstack.sim.body.RobotBody.capsules`).  PyBullet simulates no self-collision on the robot and
a trial's contact query looks at obstacles only, so a serpentine looping back into the arm would pass through
it unseen: the scripted planner's tour that loops back past its start put the tip link 55.7 mm into the arm's
fourth link and reported ``success: true`` (session 37; ``tests/test_self_contact.py``).  A trial now measures,
at every control step, the least surface distance between the robot's own capsules and counts the steps in
which it is <= 0; any such step makes the trial's ``reason`` ``collision`` (``contacts`` still counts obstacle
contacts only, as interfaces.md section 3 defines it, so a ``collision`` with ``contacts: 0`` is the robot
touching itself).

Which pairs: those with at least one serpentine link, and not neighbours along the chain (capsules that meet at
a joint overlap there by construction).  The arm's links against each other are left out: they are the real
arm's, whose wrist capsules overlap by construction, and the controller moves them within their limits.

Compiled (numba, :func:`navstack.jit.kernel`): the 45 pairs of the JPL robot in about 2 us a step; distances [m].
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.jit import kernel

FIRST_SERPENTINE_FRAME = 9
"""DH frame of the first serpentine joint (interfaces.md section 1): frames 9..20 carry the serpentine."""


def capsule_frames(radii: NDArray[np.float64]) -> NDArray[np.int64]:
    """The DH frame k of each shaped capsule (the frames k = 1..len(radii) with ``radii[k - 1] > 0``, in order, as
    :meth:`~navstack.sim.body.RobotBody.capsules` returns them)."""
    return (np.flatnonzero(np.asarray(radii, dtype=np.float64).reshape(-1) > 0.0) + 1).astype(np.int64)


def self_pairs(radii: NDArray[np.float64],
               first_serpentine_frame: int = FIRST_SERPENTINE_FRAME) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Index pairs ``(I, J)`` into the shaped capsules (the capsules of the frames k = 1..len(radii) with
    ``radii[k - 1] > 0``, in order, as :meth:`~navstack.sim.body.RobotBody.capsules` returns them) to check
    for self-contact: ``I < J``, not consecutive, at least one of the two a serpentine link."""
    frames = capsule_frames(radii)
    serp = frames >= first_serpentine_frame
    i, j = np.triu_indices(len(frames), k=2)
    keep = serp[i] | serp[j]
    return i[keep].astype(np.int64), j[keep].astype(np.int64)


def pair_frames(radii: NDArray[np.float64], pairs: tuple[NDArray[np.int64], NDArray[np.int64]],
                k: int) -> tuple[int, int]:
    """The DH frames whose capsules make pair ``k`` of ``pairs`` (:func:`self_pairs` of the same ``radii``)."""
    frames = capsule_frames(radii)
    return int(frames[pairs[0][k]]), int(frames[pairs[1][k]])


@kernel
def _segment_distance(p0, p1, q0, q1):  # pragma: no cover - compiled
    """The least distance [m] between the segments ``p0``-``p1`` and ``q0``-``q1`` (3-vectors each), exact for
    any segments, parallel and zero-length ones included: Ericson, *Real-Time Collision Detection*, 5.1.9 (the
    closest points' parameters s, t, each clamped to [0, 1] in turn)."""
    d1x, d1y, d1z = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d2x, d2y, d2z = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    rx, ry, rz = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z  # squared lengths
    e = d2x * d2x + d2y * d2y + d2z * d2z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-24  # a squared length [m^2] below which a segment is a point
    s = 0.0
    t = 0.0
    if a <= eps and e <= eps:
        pass
    elif a <= eps:
        t = min(max(f / e, 0.0), 1.0)
    elif e <= eps:
        s = min(max(-c / a, 0.0), 1.0)
    else:
        denom = a * e - b * b  # >= 0; 0 for parallel segments, whose s is then arbitrary: 0
        if denom > 0.0:
            s = min(max((b * f - c * e) / denom, 0.0), 1.0)
        t = (b * s + f) / e
        if t < 0.0:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        elif t > 1.0:
            t = 1.0
            s = min(max((b - c) / a, 0.0), 1.0)
    gx = rx + d1x * s - d2x * t
    gy = ry + d1y * s - d2y * t
    gz = rz + d1z * s - d2z * t
    return math.sqrt(gx * gx + gy * gy + gz * gz)


@kernel
def _distances(p0, p1, q0, q1, out):  # pragma: no cover - compiled
    for k in range(out.shape[0]):
        out[k] = _segment_distance(p0[k], p1[k], q0[k], q1[k])


@kernel
def _least_gap(a, b, r, i, j):  # pragma: no cover - compiled
    best = math.inf
    at = -1
    for k in range(i.shape[0]):
        m, n = i[k], j[k]
        gap = _segment_distance(a[m], b[m], a[n], b[n]) - r[m] - r[n]
        if gap < best:
            best = gap
            at = k
    return best, at


def segment_distances(p0: NDArray[np.float64], p1: NDArray[np.float64], q0: NDArray[np.float64],
                      q1: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least distances [m] between the segments ``p0[k]``-``p1[k]`` and ``q0[k]``-``q1[k]`` (each (K, 3)),
    exact for any segments, parallel and zero-length ones included (:func:`_segment_distance`)."""
    arrays = [np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3) for x in (p0, p1, q0, q1)]
    out = np.empty(len(arrays[0]))
    _distances(*arrays, out)
    return out


def self_clearance(a: NDArray[np.float64], b: NDArray[np.float64], r: NDArray[np.float64],
                   pairs: tuple[NDArray[np.int64], NDArray[np.int64]]) -> tuple[float, int]:
    """The least surface distance [m] between the capsules ``a[k]``-``b[k]`` of radius ``r[k]`` over
    ``pairs`` (:func:`self_pairs`; negative = overlap), and the index of that pair (inf, -1 without pairs)."""
    gap, k = _least_gap(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64),
                        np.ascontiguousarray(r, dtype=np.float64), pairs[0], pairs[1])
    return float(gap), int(k)
