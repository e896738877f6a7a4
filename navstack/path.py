"""Slithering path memory: the tip's desired path, and the chain of points that slither along it.

The paper (section 2) makes every serpentine joint "track the same task-space path
as the tip while remaining one link length apart".  :class:`PathMemory` records the
tip's *desired* path ``x_d(t)`` online as a polyline parameterised by arc length
and answers, for the chain tip -> J1 -> ... -> J6, the desired joint points
``y_d,i`` and their velocities.

Recording
    :meth:`PathMemory.record` makes ``x`` the path's *head* (its end, arc length
    :attr:`PathMemory.end_arc_length`) and appends it as a new vertex only if it
    is at least ``spacing`` (default 1 mm) from the last vertex, so a slow or
    stopped tip does not fill the memory and every segment has length >=
    ``spacing`` (the initial backbone segments are one link long).  The vertices
    live in preallocated arrays that double in size when full (amortised O(1)).
    The part of the path between the last vertex and the head (shorter than
    ``spacing``) is a "live" segment: used by :meth:`chain` but not stored.

Reverse slithering
    A tip that backs up along its own path does not record: the path is cut back
    to it (:meth:`PathMemory.truncate`, or :meth:`PathMemory.advance` with
    ``reverse=True``, which first finds the tip's arc length near the end of the
    path).  Truncation steps back over the dropped vertices only (each vertex is
    dropped at most once after it was recorded: O(1) amortised), and the turning
    point becomes a vertex, so when the tip goes forward again the new branch is
    recorded from exactly there; chain points still on the old part keep
    following it.  :meth:`PathMemory.point_at` gives the point and tangent at an
    arc length (what a retreat command follows, :mod:`navstack.retreat`).

Initial path
    The path starts as the robot's initial backbone J6, J5, ..., J1, tip, with a
    straight extension of ``extension`` (default three links) behind J6 along
    J5 -> J6, so slithering is defined from the first step and a short retreat
    of the tip stays on a defined path.  Past the extension's end the first
    segment's line is extrapolated (:attr:`PathMemory.overruns` counts it): every
    chord point beyond it lies one link further back on that line.

Chord rule
    With ``P_0`` the tip, ``P_i`` is the point of the path *one link (Euclidean
    chord, ``link_length``) behind* ``P_{i-1}``: the first crossing of the sphere
    ``|p - P_{i-1}| = L`` met going backward along the path from ``P_{i-1}``.
    Each joint keeps a segment pointer.  A pointer moves forward while the next
    vertex is still at least ``L`` from ``P_{i-1}`` (and steps back only if its
    vertex has fallen inside the sphere, e.g. when the tip retreats); the
    crossing is then solved in closed form on that one segment.  The work per
    step is therefore proportional to the number of vertices each chord point
    passed (O(1) amortised; :attr:`PathMemory.last_iterations` counts pointer
    moves), never a scan of the history.  The pointer finds the first crossing
    backward from ``P_{i-1}`` whenever ``|path(s) - P_{i-1}|`` crosses ``L`` once
    between the old and new chord points, which holds for a path whose radius
    of curvature exceeds ``L / 2`` and that does not return within a link of
    itself; on a path that curls back into the sphere it returns the crossing
    reached first from the old pointer.  When the tip runs backwards the chord
    points run back too: a pointer whose vertex falls inside the sphere steps back.

Velocities
    With ``P_i = path(s_i)`` and ``t_i`` the unit tangent of the segment holding
    ``P_i``, ``d/dt |P_i - P_{i-1}|^2 = 0`` gives
    ``sdot_i = ((P_i - P_{i-1}) . Pdot_{i-1}) / ((P_i - P_{i-1}) . t_i)`` and
    ``Pdot_i = t_i sdot_i``, with ``Pdot_0`` the tip velocity.  If the chord is
    (nearly) perpendicular to the tangent (``|cos| < 1e-6``) the rate is not
    defined and ``sdot_i`` is set to 0 (counted in :attr:`PathMemory.singular`).

Units: metres, metres per second.  The hot functions are ``numba.njit`` kernels
(:func:`record_into`, :func:`chain_into`, :func:`window_distance`) that the
controller's slither task calls through :meth:`PathMemory.advance`.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

SINGULAR_COS = 1e-6
"""Chord/tangent cosine below which the chord-rule rate is treated as singular."""
MIN_ARC = 1e-9
"""Smallest arc length [m] the path may be cut back to (the extension's end is at 0)."""


# --------------------------------------------------------------------------- kernels
# head: (4,) [x, y, z, s], the last recorded tip and its arc length (on the live segment V[n-1] -> head)
# stats: (6,) int64 [pointer moves, extrapolations, singular rates] of the last chain evaluation, then
# the same three summed over every evaluation
ADVANCE_OK, ADVANCE_OFF_PATH, ADVANCE_BAD_INPUT, ADVANCE_FULL = range(4)


@numba.njit(cache=True)
def record_into(V, S, n, x, spacing, head):  # pragma: no cover - jitted
    """Record the tip ``x`` as the head; append it to ``V[:n]`` (arc lengths ``S``) if >= ``spacing`` from ``V[n-1]``.

    Returns the new vertex count.  The caller guarantees ``n < len(V)``.
    """
    dx = x[0] - V[n - 1, 0]
    dy = x[1] - V[n - 1, 1]
    dz = x[2] - V[n - 1, 2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    head[0], head[1], head[2] = x[0], x[1], x[2]
    head[3] = S[n - 1] + dist
    if dist < spacing:
        return n
    V[n, 0] = x[0]
    V[n, 1] = x[1]
    V[n, 2] = x[2]
    S[n] = head[3]
    return n + 1


@numba.njit(cache=True)
def truncate_into(V, S, n, s, head):  # pragma: no cover - jitted
    """Drop the path beyond arc length ``s`` (``MIN_ARC < s <= head[3]``); the point at ``s`` becomes the head.

    Vertices beyond ``s`` are dropped by stepping back from the end (each vertex is dropped at most once
    after it was recorded: O(1) amortised).  The point at ``s`` becomes a vertex unless it is within
    1e-12 m of arc of the vertex before it (then the head sits on that vertex), so a new branch recorded
    afterwards starts exactly at the turning point.  Returns the new vertex count (>= 2).
    """
    if s >= head[3]:
        return n
    if s >= S[n - 1]:  # on the live segment V[n-1] -> head: only the head moves back
        f = (s - S[n - 1]) / (head[3] - S[n - 1])
        for c in range(3):
            head[c] = V[n - 1, c] + f * (head[c] - V[n - 1, c])
        head[3] = s
        return n
    while n > 1 and S[n - 1] > s:
        n -= 1
    # S[n-1] <= s < S[n]; V[n] is the old vertex after it, still in the array
    f = (s - S[n - 1]) / (S[n] - S[n - 1])
    for c in range(3):
        head[c] = V[n - 1, c] + f * (V[n, c] - V[n - 1, c])
    head[3] = s
    if s - S[n - 1] > 1e-12:
        V[n, 0], V[n, 1], V[n, 2] = head[0], head[1], head[2]
        S[n] = s
        n += 1
    return n


@numba.njit(cache=True, inline="always")
def _project(ax, ay, az, bx, by, bz, px, py, pz):  # pragma: no cover - jitted
    """Closest point of segment a-b to p: (parameter in [0, 1], squared distance)."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    wx, wy, wz = px - ax, py - ay, pz - az
    A = dx * dx + dy * dy + dz * dz
    t = (wx * dx + wy * dy + wz * dz) / A if A > 0.0 else 0.0
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    ex, ey, ez = wx - t * dx, wy - t * dy, wz - t * dz
    return t, ex * ex + ey * ey + ez * ez


@numba.njit(cache=True)
def locate_into(V, S, n, head, x, w_min):  # pragma: no cover - jitted
    """Arc length and distance [m] of the point of the path nearest ``x`` within a window behind the head.

    With ``delta = |x - head|`` the window is the last ``max(w_min, 4 delta)`` of arc (the argument of
    :meth:`PathMemory.distance_to_path`: exact on a path whose radius of curvature exceeds ``2 delta``).
    Work proportional to the vertices in the window, never the whole history.  Returns (s, distance).
    """
    hs = head[3]
    dx, dy, dz = x[0] - head[0], x[1] - head[1], x[2] - head[2]
    d2 = dx * dx + dy * dy + dz * dz
    w = max(w_min, 4.0 * math.sqrt(d2))
    best, best_s = d2, hs
    if hs > S[n - 1]:  # the live segment
        t, e2 = _project(V[n - 1, 0], V[n - 1, 1], V[n - 1, 2], head[0], head[1], head[2], x[0], x[1], x[2])
        if e2 < best:
            best, best_s = e2, S[n - 1] + t * (hs - S[n - 1])
    j = n - 2
    while j >= 0 and S[j + 1] >= hs - w:
        t, e2 = _project(V[j, 0], V[j, 1], V[j, 2], V[j + 1, 0], V[j + 1, 1], V[j + 1, 2], x[0], x[1], x[2])
        if e2 < best:
            best, best_s = e2, S[j] + t * (S[j + 1] - S[j])
        j -= 1
    return best_s, math.sqrt(best)


@numba.njit(cache=True, inline="always")
def _dist2(V, k, px, py, pz):  # pragma: no cover - jitted
    dx = V[k, 0] - px
    dy = V[k, 1] - py
    dz = V[k, 2] - pz
    return dx * dx + dy * dy + dz * dz


@numba.njit(cache=True, inline="always")
def _move_pointer(V, k, k_prev, px, py, pz, L2):  # pragma: no cover - jitted
    """Pointer ``k`` moved to the segment holding the crossing behind P (see the module docstring).

    Forward while the next vertex is still outside the sphere, back while ``V[k]`` is inside it.
    Returns (k, moves).
    """
    moves = 0
    if _dist2(V, k, px, py, pz) >= L2:
        while k + 1 <= k_prev and _dist2(V, k + 1, px, py, pz) >= L2:
            k += 1
            moves += 1
    else:
        while k > 0 and _dist2(V, k, px, py, pz) < L2:
            k -= 1
            moves += 1
    return k, moves


@numba.njit(cache=True, inline="always")
def _sphere_roots(ax, ay, az, dx, dy, dz, px, py, pz, L2):  # pragma: no cover - jitted
    """Coefficients of ``|a + t d - p|^2 - L^2 = A t^2 + 2 B t + C`` and ``sqrt(B^2 - A C)`` (>= 0)."""
    wx, wy, wz = ax - px, ay - py, az - pz
    A = dx * dx + dy * dy + dz * dz
    B = wx * dx + wy * dy + wz * dz
    C = wx * wx + wy * wy + wz * wz - L2
    return A, B, C, math.sqrt(max(B * B - A * C, 0.0))


@numba.njit(cache=True)
def chain_into(V, n, x_tip, xdot_tip, L, ptr, pts, vel, seg, par, stats):  # pragma: no cover - jitted
    """Chord points ``pts`` (m, 3) behind ``x_tip`` on the path ``V[:n]`` + live segment, and velocities.

    ``ptr`` (m,) are the per-joint segment pointers (updated in place); ``seg``
    and ``par`` receive each point's segment index and segment parameter
    (``pts[i] = V[seg] + par * (next - V[seg])``; ``par < 0`` on the extrapolation
    behind ``V[0]``).  ``stats`` (6,) int64 gets [pointer moves, extrapolations past
    V[0], singular rates] of this call in [0:3], added to the totals in [3:6].
    Requires ``n >= 2``.  (One loop over the joints, kept whole: it is the hot path.)
    """
    L2 = L * L
    px, py, pz = x_tip[0], x_tip[1], x_tip[2]
    vx, vy, vz = xdot_tip[0], xdot_tip[1], xdot_tip[2]
    k_prev = n - 1  # the tip lies on the live segment V[n-1] -> x_tip
    beyond = False  # P_{i-1} lies on the extrapolation behind V[0]
    iters = overruns = singular = 0
    for i in range(ptr.shape[0]):
        k = min(max(ptr[i], 0), k_prev)
        if not beyond:
            k, moves = _move_pointer(V, k, k_prev, px, py, pz, L2)
            iters += moves
        if beyond or (k == 0 and _dist2(V, 0, px, py, pz) < L2):
            # behind V[0]: on the line V[0] + t e (e = V[1] - V[0], forward).  The two roots straddle
            # P's own parameter (or 0, with V[0] inside the sphere): the smaller is behind P_{i-1}
            k = 0
            ax, ay, az = V[0, 0], V[0, 1], V[0, 2]
            dx, dy, dz = V[1, 0] - ax, V[1, 1] - ay, V[1, 2] - az
            A, B, C, root = _sphere_roots(ax, ay, az, dx, dy, dz, px, py, pz, L2)
            t = (-B - root) / A
            tx, ty, tz = dx, dy, dz
            overruns += 1
            beyond = True
        else:
            ax, ay, az = V[k, 0], V[k, 1], V[k, 2]
            if k + 1 <= k_prev:
                bx, by, bz = V[k + 1, 0], V[k + 1, 1], V[k + 1, 2]
            else:  # the segment holding P_{i-1}: only its part behind P_{i-1}
                bx, by, bz = px, py, pz
            dx, dy, dz = bx - ax, by - ay, bz - az
            A, B, C, root = _sphere_roots(ax, ay, az, dx, dy, dz, px, py, pz, L2)
            # f(0) = C >= 0 > f(1): the one root in [0, 1) is the smaller one (stable form)
            t = C / (root - B) if root - B > 0.0 else 0.0
            # unit tangent of the segment (direction of travel): the whole segment's if P_{i-1} is on it
            if k == k_prev and k + 1 <= n - 1:
                tx, ty, tz = V[k + 1, 0] - ax, V[k + 1, 1] - ay, V[k + 1, 2] - az
            else:
                tx, ty, tz = dx, dy, dz
        qx, qy, qz = ax + t * dx, ay + t * dy, az + t * dz
        tn = math.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx / tn, ty / tn, tz / tn
        cx, cy, cz = qx - px, qy - py, qz - pz
        den = cx * tx + cy * ty + cz * tz
        if abs(den) < SINGULAR_COS * L:
            sdot = 0.0
            singular += 1
        else:
            sdot = (cx * vx + cy * vy + cz * vz) / den
        vx, vy, vz = tx * sdot, ty * sdot, tz * sdot
        pts[i, 0], pts[i, 1], pts[i, 2] = qx, qy, qz
        vel[i, 0], vel[i, 1], vel[i, 2] = vx, vy, vz
        seg[i] = k
        par[i] = t
        ptr[i] = k
        k_prev = k
        px, py, pz = qx, qy, qz
    stats[0], stats[1], stats[2] = iters, overruns, singular
    stats[3] += iters
    stats[4] += overruns
    stats[5] += singular


@numba.njit(cache=True)
def advance_into(V, S, nv, head, iptr, pv, par, stats, x, xdot, reverse, L, spacing, tol):  # pragma: no cover
    """One step of the path memory: record ``x`` (or, ``reverse``, cut the path back to it), then the chain.

    ``nv`` (1,) int64 holds the vertex count (updated); ``iptr`` (2, m) the pointers and segments,
    ``pv`` (2, m, 3) the points and velocities of :func:`chain_into`.  With ``reverse`` the point of the path nearest
    ``x`` behind the head is located (:func:`locate_into`, window 4 * ``spacing``) and the path truncated
    there; if ``x`` is more than ``tol`` from the path nothing changes and ``ADVANCE_OFF_PATH`` is
    returned.  Non-finite input: ``ADVANCE_BAD_INPUT``; fewer than two free vertex slots: ``ADVANCE_FULL``
    (nothing changes in either case).
    """
    n = nv[0]
    if n + 2 > V.shape[0]:
        return ADVANCE_FULL
    for c in range(3):
        if not (math.isfinite(x[c]) and math.isfinite(xdot[c])):
            return ADVANCE_BAD_INPUT
    if reverse:
        s, dist = locate_into(V, S, n, head, x, 4.0 * spacing)
        if dist > tol or s <= MIN_ARC:
            return ADVANCE_OFF_PATH
        n = truncate_into(V, S, n, s, head)
    else:
        n = record_into(V, S, n, x, spacing, head)
    nv[0] = n
    chain_into(V, n, x, xdot, L, iptr[0], pv[0], pv[1], iptr[1], par, stats)
    return ADVANCE_OK


@numba.njit(cache=True, inline="always")
def _seg_dist2(V, j, px, py, pz):  # pragma: no cover - jitted
    ax, ay, az = V[j, 0], V[j, 1], V[j, 2]
    dx, dy, dz = V[j + 1, 0] - ax, V[j + 1, 1] - ay, V[j + 1, 2] - az
    wx, wy, wz = px - ax, py - ay, pz - az
    A = dx * dx + dy * dy + dz * dz
    t = (wx * dx + wy * dy + wz * dz) / A if A > 0.0 else 0.0
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    ex, ey, ez = wx - t * dx, wy - t * dy, wz - t * dz
    return ex * ex + ey * ey + ez * ez


@numba.njit(cache=True)
def full_distance(V, n, p):  # pragma: no cover - jitted
    """Exact distance [m] from ``p`` to the polyline ``V[:n]`` (scans every segment)."""
    best = _dist2(V, 0, p[0], p[1], p[2])
    for j in range(n - 1):
        d2 = _seg_dist2(V, j, p[0], p[1], p[2])
        if d2 < best:
            best = d2
    return math.sqrt(best)


@numba.njit(cache=True)
def max_full_distance(V, n, P):  # pragma: no cover - jitted
    """The largest :func:`full_distance` of the rows of ``P`` (k, 3) (``-inf`` for k = 0)."""
    out = -np.inf
    for i in range(P.shape[0]):
        out = max(out, full_distance(V, n, P[i]))
    return out


@numba.njit(cache=True)
def window_distance(V, S, n, p, k, t, w_min):  # pragma: no cover - jitted
    """Distance [m] from ``p`` to the segments of ``V[:n]`` within an arc-length window of a chord point.

    The chord point is ``c = V[k] + t (V[k+1] - V[k])`` (arc length ``s_c``);
    with ``delta = |p - c|`` the window is ``s_c +- max(w_min, 4 delta)``.
    """
    n_seg = n - 1
    if k > n_seg - 1:
        k = n_seg - 1
    t = min(max(t, 0.0), 1.0)  # c on the recorded polyline (not on an extrapolation)
    seg_len = S[k + 1] - S[k]
    s_c = S[k] + t * seg_len
    cx = V[k, 0] + t * (V[k + 1, 0] - V[k, 0])
    cy = V[k, 1] + t * (V[k + 1, 1] - V[k, 1])
    cz = V[k, 2] + t * (V[k + 1, 2] - V[k, 2])
    dx, dy, dz = p[0] - cx, p[1] - cy, p[2] - cz
    delta = math.sqrt(dx * dx + dy * dy + dz * dz)
    w = max(w_min, 4.0 * delta)
    best = delta * delta
    j = k
    while j >= 0 and S[j + 1] >= s_c - w:
        d2 = _seg_dist2(V, j, p[0], p[1], p[2])
        if d2 < best:
            best = d2
        j -= 1
    j = k + 1
    while j < n_seg and S[j] <= s_c + w:
        d2 = _seg_dist2(V, j, p[0], p[1], p[2])
        if d2 < best:
            best = d2
        j += 1
    return math.sqrt(best)


# --------------------------------------------------------------------------- class
def _vec3(x: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector [m], got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


class PathMemory:
    """The recorded desired tip path and the slithering chain on it (see the module docstring).

    Parameters
    ----------
    backbone:
        (m, 3) initial backbone, tip first: tip, J1, ..., J_{m-1} [m]
        (for the JPL robot ``chain.points_and_jacobians(q0)[0]``, m = 7).
        Consecutive points must be ``link_length`` apart (to 1e-6 relative).
    link_length:
        Chord between consecutive chain points [m] (0.20 for the JPL robot).
    spacing:
        Minimum distance between recorded vertices [m].
    capacity:
        Initial number of vertex slots (grows by doubling).
    extension:
        Length of the straight path behind J_{m-1} [m]; default three links,
        at least two.
    """

    def __init__(
        self,
        backbone: ArrayLike,
        link_length: float = 0.2,
        spacing: float = 1e-3,
        capacity: int = 4096,
        extension: float | None = None,
    ) -> None:
        bb = np.array(backbone, dtype=np.float64)
        if bb.ndim != 2 or bb.shape[1] != 3 or bb.shape[0] < 2:
            raise ValueError(f"backbone must have shape (m, 3) with m >= 2 (tip first), got {bb.shape}")
        if not np.isfinite(bb).all():
            raise ValueError("backbone must be finite")
        if not (np.isfinite(link_length) and link_length > 0):
            raise ValueError(f"link_length must be a positive length [m], got {link_length}")
        if not (np.isfinite(spacing) and 0 < spacing <= 0.1 * link_length):
            raise ValueError(f"spacing must be in (0, link_length/10] [m], got {spacing}")
        gaps = np.linalg.norm(np.diff(bb, axis=0), axis=1)
        bad = np.flatnonzero(np.abs(gaps - link_length) > 1e-6 * link_length)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"backbone points {i} and {i + 1} are {gaps[i]:.9f} m apart, expected link_length={link_length}"
            )
        ext = 3.0 * link_length if extension is None else float(extension)
        if not (np.isfinite(ext) and ext >= 2.0 * link_length):
            raise ValueError(f"extension must be >= 2 link lengths ({2 * link_length} m), got {extension}")
        m = bb.shape[0]
        capacity = max(int(capacity), 2 * (m + 1))
        self.link_length = float(link_length)
        self.spacing = float(spacing)
        self.n_joints = m - 1
        self._V = np.zeros((capacity, 3))
        self._S = np.zeros(capacity)
        back = bb[::-1]  # J_{m-1}, ..., J1, tip
        direction = (back[0] - back[1]) / np.linalg.norm(back[0] - back[1])
        self._V[0] = back[0] + ext * direction
        self._V[1 : m + 1] = back
        self._S[1] = ext
        self._S[2 : m + 1] = ext + np.cumsum(gaps[::-1])
        self._nv = np.array([m + 1], dtype=np.int64)
        self._head = np.append(bb[0], self._S[m])
        self.start_arc_length = float(self._S[m])
        """Arc length of the initial tip [m] (where a full retraction ends)."""
        # joint i (1-based) sits on vertex m - i: the segment starting there, parameter 0
        # pointers and segments, points and velocities: pairs of rows of one array each (fewer kernel arguments)
        self._iptr = np.array([[m - i for i in range(1, m)]] * 2, dtype=np.int64)
        self.ptr = self._iptr[0]
        self.seg = self._iptr[1]
        self._pv = np.zeros((2, m - 1, 3))
        self.pts = self._pv[0]
        self.pts[:] = bb[1:]
        self.vel = self._pv[1]
        self.par = np.zeros(m - 1)
        self.stats = np.zeros(6, dtype=np.int64)
        self._kernel_state = (self._V, self._S, self._nv, self._head, self._iptr, self._pv, self.par, self.stats)

    # ---- storage -------------------------------------------------------
    @property
    def n_points(self) -> int:
        """Number of recorded vertices (extension end and initial backbone included)."""
        return int(self._nv[0])

    @property
    def points(self) -> NDArray[np.float64]:
        """Copy of the recorded vertices (n, 3) [m], oldest first."""
        return self._V[: self.n_points].copy()

    @property
    def arc_length(self) -> NDArray[np.float64]:
        """Copy of the cumulative arc length at each vertex (n,) [m], 0 at the extension's end."""
        return self._S[: self.n_points].copy()

    @property
    def length(self) -> float:
        """Arc length of the last recorded vertex [m] (extension included; see :attr:`end_arc_length`)."""
        return float(self._S[self.n_points - 1])

    @property
    def head(self) -> NDArray[np.float64]:
        """The last recorded tip (3,) [m] (copy): the end of the path, a vertex or within ``spacing`` of one."""
        return self._head[:3].copy()

    @property
    def end_arc_length(self) -> float:
        """Arc length of the path's end, :attr:`head` [m] (the live segment after the last vertex included)."""
        return float(self._head[3])

    @property
    def capacity(self) -> int:
        """Current number of vertex slots."""
        return self._V.shape[0]

    @property
    def last_iterations(self) -> int:
        """Pointer moves made by the last chain evaluation (all joints together)."""
        return int(self.stats[0])

    @property
    def total_iterations(self) -> int:
        """Pointer moves over every chain evaluation."""
        return int(self.stats[3])

    @property
    def overruns(self) -> int:
        """Chord points placed on the extrapolation behind the extension's end, over every evaluation."""
        return int(self.stats[4])

    @property
    def singular(self) -> int:
        """Chord-rule rates set to 0 as singular (chord perpendicular to the path), over every evaluation."""
        return int(self.stats[5])

    def ensure_capacity(self, extra: int = 1) -> None:
        """Grow (double) the vertex arrays so ``extra`` more vertices fit."""
        n = self.n_points
        need = n + extra
        if need <= self._V.shape[0]:
            return
        cap = self._V.shape[0]
        while cap < need:
            cap *= 2
        V = np.zeros((cap, 3))
        S = np.zeros(cap)
        V[:n] = self._V[:n]
        S[:n] = self._S[:n]
        self._V, self._S = V, S
        self._kernel_state = (self._V, self._S, self._nv, self._head, self._iptr, self._pv, self.par, self.stats)

    # ---- API -----------------------------------------------------------
    def record(self, x_tip: ArrayLike) -> bool:
        """Record the desired tip position ``x_tip`` [m] as the new head; True if it became a new vertex."""
        x = _vec3(x_tip, "x_tip")
        self.ensure_capacity(1)
        n0 = self.n_points
        self._nv[0] = record_into(self._V, self._S, n0, x, self.spacing, self._head)
        return self.n_points != n0

    def point_at(self, s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The path's point at arc length ``s`` [m] and its unit tangent (direction of recording).

        ``0 <= s <= end_arc_length``; O(log n) (a binary search over the vertices).  On the live
        segment (after the last vertex) the point lies between the last vertex and :attr:`head`.
        """
        end = self.end_arc_length
        if not (np.isfinite(s) and 0.0 <= s <= end):
            raise ValueError(f"s must be an arc length in [0, {end}] m, got {s}")
        n = self.n_points
        S = self._S
        if s >= S[n - 1]:
            a, b, s0, s1 = self._V[n - 1], self._head[:3], S[n - 1], end
            if s1 <= s0:  # the head is the last vertex: its segment is the last recorded one
                a, b, s0, s1 = self._V[n - 2], self._V[n - 1], S[n - 2], S[n - 1]
        else:
            k = min(int(np.searchsorted(S[:n], s, side="right")) - 1, n - 2)
            a, b, s0, s1 = self._V[k], self._V[k + 1], S[k], S[k + 1]
        d = b - a
        f = (s - s0) / (s1 - s0)
        return a + f * d, d / np.linalg.norm(d)

    def points_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """The path's points (K, 3) [m] at the arc lengths ``s`` (K,) [m]: :meth:`point_at` for many
        (the same arithmetic, so the same values), without the tangents."""
        s = np.asarray(s, dtype=np.float64).reshape(-1)
        end = self.end_arc_length
        if len(s) and not (np.isfinite(s).all() and s.min() >= 0.0 and s.max() <= end):
            raise ValueError(f"s must be arc lengths in [0, {end}] m, got {s.min()} .. {s.max()}")
        n = self.n_points
        S = self._S[:n]
        k = np.minimum(np.searchsorted(S, s, side="right") - 1, n - 2)
        a, b, s0, s1 = self._V[k], self._V[k + 1], S[k], S[k + 1]
        live = s >= S[n - 1]
        if live.any():
            if end > S[n - 1]:  # the live segment, from the last vertex to the head
                a[live], b[live], s0[live], s1[live] = self._V[n - 1], self._head[:3], S[n - 1], end
            else:  # the head is the last vertex: its segment is the last recorded one
                a[live], b[live], s0[live], s1[live] = self._V[n - 2], self._V[n - 1], S[n - 2], S[n - 1]
        f = (s - s0) / (s1 - s0)
        return a + f[:, None] * (b - a)

    def locate(self, x: ArrayLike) -> tuple[float, float]:
        """Arc length [m] of the point of the path nearest ``x`` near its end, and the distance [m].

        Only the last ``max(4 spacing, 4 |x - head|)`` of arc are searched (see :func:`locate_into`),
        so the cost does not grow with the history; for a point on the path a few steps behind the head.
        """
        p = _vec3(x, "x")
        s, d = locate_into(self._V, self._S, self.n_points, self._head, p, 4.0 * self.spacing)
        return float(s), float(d)

    def truncate(self, s: float) -> None:
        """Drop the path beyond arc length ``s`` [m]: the point at ``s`` becomes the end (:attr:`head`).

        For a tip moving back along its own path.  ``0 < s <= end_arc_length``; O(1) amortised (each
        dropped vertex is visited once).  Recording afterwards starts a new branch at that point; chain
        points behind ``s`` stay where they are on the old path.
        """
        end = self.end_arc_length
        if not (np.isfinite(s) and MIN_ARC < s <= end):
            raise ValueError(f"truncate: s must be an arc length in (0, {end}] m, got {s}")
        self._nv[0] = truncate_into(self._V, self._S, self.n_points, float(s), self._head)

    def advance(self, x_tip: ArrayLike, xdot_tip: ArrayLike, reverse: bool = False,
                tolerance: float = 1e-3) -> None:
        """One control step: record ``x_tip`` (or cut the path back to it), then place the chain.

        ``reverse=False``: as :meth:`record` then :meth:`chain`.  ``reverse=True``: ``x_tip`` must lie on
        the path near its end, behind the head (a tip retracing its path): the path is truncated at the
        nearest point (:meth:`locate`) instead of recorded; ``ValueError`` if that point is more than
        ``tolerance`` [m] away (then nothing changes).  The chain is in :attr:`pts`, :attr:`vel`.
        """
        x = np.asarray(x_tip, dtype=np.float64)
        xd = np.asarray(xdot_tip, dtype=np.float64)
        if x.shape != (3,) or xd.shape != (3,):
            raise ValueError(f"x_tip and xdot_tip must be 3-vectors, got shapes {x.shape} and {xd.shape}")
        status = advance_into(*self._kernel_state, x, xd, reverse, self.link_length, self.spacing, tolerance)
        if status == ADVANCE_FULL:
            self.ensure_capacity(2)
            status = advance_into(*self._kernel_state, x, xd, reverse, self.link_length, self.spacing, tolerance)
        if status:
            self._advance_error(status, x, xd)

    @property
    def kernel_state(self) -> tuple[NDArray, ...]:
        """The path's arrays in the order :func:`advance_into` takes them first (V, S, vertex count, head,
        pointers, points and velocities, parameters, counters): for a compiled caller that advances the path
        inside its own kernel (:mod:`navstack.control.fast`).  The storage is replaced when it grows: read
        this afresh for every call, and on ``ADVANCE_FULL`` call :meth:`ensure_capacity` and retry."""
        return self._kernel_state

    def _advance_error(self, status: int, x: NDArray[np.float64], xd: NDArray[np.float64]) -> None:
        if status == ADVANCE_BAD_INPUT:
            _vec3(x, "x_tip")
            _vec3(xd, "xdot_tip")
        s, d = self.locate(x)
        raise ValueError(
            f"reverse tip command {x.tolist()} is {d:.3g} m from the recorded path near its end (nearest at "
            f"arc length {s:.4f} m of {self.end_arc_length:.4f} m): a retreat must retrace the path"
        )

    def chain(
        self, x_tip: ArrayLike, xdot_tip: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Desired joint points J1..J_{m-1} (m-1, 3) [m] and their velocities (m-1, 3) [m/s].

        ``x_tip`` is the current desired tip (normally the point just passed to
        :meth:`record`), ``xdot_tip`` its velocity.  Updates the pointers;
        returns copies.
        """
        x = _vec3(x_tip, "x_tip")
        xd = _vec3(xdot_tip, "xdot_tip")
        chain_into(self._V, self.n_points, x, xd, self.link_length, self.ptr, self.pts, self.vel, self.seg,
                   self.par, self.stats)
        return self.pts.copy(), self.vel.copy()

    def distance_to_path(self, p: ArrayLike, joint: int | None = None, window: float = 0.02) -> float:
        """Distance [m] from ``p`` to the recorded polyline.

        ``joint=None``: exact, over every recorded segment (O(n)).
        ``joint=i`` (1-based, J_i): only the segments within an arc-length window
        ``s_c +- max(window, 4 delta)`` around J_i's current chord point ``c``
        (``delta = |p - c|``).  The true nearest point ``q*`` satisfies
        ``|q* - p| <= delta``, hence ``|q* - c| <= 2 delta``; on a path with
        radius of curvature >= ``2 delta`` that does not come back within
        ``2 delta`` of ``c`` from farther along, the arc from ``c`` to ``q*`` is
        at most ``pi delta < 4 delta`` long, so the window contains ``q*`` and
        the result is exact.  Otherwise it is an upper bound on the distance
        (never an underestimate, so a maximum over a run stays conservative).
        """
        x = _vec3(p, "p")
        n = self.n_points
        if joint is None:
            return float(full_distance(self._V, n, x))
        if not 1 <= joint <= self.n_joints:
            raise ValueError(f"joint must be in 1..{self.n_joints} (J1 nearest the tip), got {joint}")
        if not (np.isfinite(window) and window >= 0):
            raise ValueError(f"window must be a non-negative length [m], got {window}")
        i = joint - 1
        return float(window_distance(self._V, self._S, n, x, int(self.seg[i]), float(self.par[i]),
                                     float(window)))

    def max_distance_to_path(self, points: ArrayLike) -> float:
        """The largest exact :meth:`distance_to_path` (``joint=None``) of the rows of ``points`` (k, 3) [m], in
        one compiled call (``-inf`` for no rows)."""
        P = np.ascontiguousarray(points, dtype=np.float64)
        if P.ndim != 2 or P.shape[1] != 3 or not np.isfinite(P).all():
            raise ValueError(f"points must be finite (k, 3) positions, got shape {P.shape}")
        return float(max_full_distance(self._V, self.n_points, P))

    def max_deviation(self, points: ArrayLike, window: float = 0.02) -> float:
        """Largest windowed :meth:`distance_to_path` of J1..J_{m-1} ``points`` (m-1, 3) [m].

        This is the per-step term of the ``slither_deviation_max`` metric.
        """
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape != (self.n_joints, 3):
            raise ValueError(f"points must have shape ({self.n_joints}, 3) (J1 first), got {pts.shape}")
        return max(self.distance_to_path(pts[i], joint=i + 1, window=window) for i in range(self.n_joints))
