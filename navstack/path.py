"""Slithering path memory: the tip's desired path, and the chain of points that slither along it.

The paper (section 2) makes every serpentine joint "track the same task-space path
as the tip while remaining one link length apart".  :class:`PathMemory` records the
tip's *desired* path ``x_d(t)`` online as a polyline parameterised by arc length
and answers, for the chain tip -> J1 -> ... -> J6, the desired joint points
``y_d,i`` and their velocities.

Recording
    :meth:`PathMemory.record` appends ``x`` as a new vertex only if it is at
    least ``spacing`` (default 1 mm) from the last vertex, so a slow or stopped
    tip does not fill the memory and every segment has length >= ``spacing``
    (the initial backbone segments are one link long).  The vertices live in
    preallocated arrays that double in size when full (amortised O(1)).  The
    part of the path between the last vertex and the current tip (shorter than
    ``spacing``) is a "live" segment: it is used by :meth:`chain` but not stored.

Initial path
    The path starts as the robot's initial backbone J6, J5, ..., J1, tip, with a
    straight extension of ``extension`` (default three links) behind J6 along
    J5 -> J6, so slithering is defined from the first step and a short retreat
    of the tip stays on a defined path.  Past the extension's end the first
    segment's line is extrapolated (:attr:`PathMemory.overruns` counts it).

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
    reached first from the old pointer.

Velocities
    With ``P_i = path(s_i)`` and ``t_i`` the unit tangent of the segment holding
    ``P_i``, ``d/dt |P_i - P_{i-1}|^2 = 0`` gives
    ``sdot_i = ((P_i - P_{i-1}) . Pdot_{i-1}) / ((P_i - P_{i-1}) . t_i)`` and
    ``Pdot_i = t_i sdot_i``, with ``Pdot_0`` the tip velocity.  If the chord is
    (nearly) perpendicular to the tangent (``|cos| < 1e-6``) the rate is not
    defined and ``sdot_i`` is set to 0 (counted in :attr:`PathMemory.singular`).

Units: metres, metres per second.  The hot functions are ``numba.njit`` kernels
(:func:`record_into`, :func:`chain_into`, :func:`window_distance`) that the
controller's compiled step calls directly.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

SINGULAR_COS = 1e-6
"""Chord/tangent cosine below which the chord-rule rate is treated as singular."""


# --------------------------------------------------------------------------- kernels
@numba.njit(cache=True)
def record_into(V, S, n, x, spacing):  # pragma: no cover - jitted
    """Append ``x`` to vertices ``V[:n]`` (arc lengths ``S``) if >= ``spacing`` from ``V[n-1]``.

    Returns the new vertex count.  The caller guarantees ``n < len(V)``.
    """
    dx = x[0] - V[n - 1, 0]
    dy = x[1] - V[n - 1, 1]
    dz = x[2] - V[n - 1, 2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dist < spacing:
        return n
    V[n, 0] = x[0]
    V[n, 1] = x[1]
    V[n, 2] = x[2]
    S[n] = S[n - 1] + dist
    return n + 1


@numba.njit(cache=True, inline="always")
def _dist2(V, k, px, py, pz):  # pragma: no cover - jitted
    dx = V[k, 0] - px
    dy = V[k, 1] - py
    dz = V[k, 2] - pz
    return dx * dx + dy * dy + dz * dz


@numba.njit(cache=True)
def chain_into(V, n, x_tip, xdot_tip, L, ptr, pts, vel, seg, par, stats):  # pragma: no cover - jitted
    """Chord points ``pts`` (m, 3) behind ``x_tip`` on the path ``V[:n]`` + live segment, and velocities.

    ``ptr`` (m,) are the per-joint segment pointers (updated in place); ``seg``
    and ``par`` receive each point's segment index and segment parameter
    (``pts[i] = V[seg] + par * (next - V[seg])``).  ``stats`` (3,) int64 gets
    [pointer moves, extrapolations past V[0], singular rates].  Returns nothing.
    """
    m = ptr.shape[0]
    L2 = L * L
    px, py, pz = x_tip[0], x_tip[1], x_tip[2]
    vx, vy, vz = xdot_tip[0], xdot_tip[1], xdot_tip[2]
    k_prev = n - 1  # the tip lies on the live segment V[n-1] -> x_tip
    iters = 0
    overruns = 0
    singular = 0
    for i in range(m):
        k = ptr[i]
        if k > k_prev:
            k = k_prev
        if k < 0:
            k = 0
        if _dist2(V, k, px, py, pz) >= L2:
            while k + 1 <= k_prev and _dist2(V, k + 1, px, py, pz) >= L2:
                k += 1
                iters += 1
        else:
            while k > 0 and _dist2(V, k, px, py, pz) < L2:
                k -= 1
                iters += 1
        ax, ay, az = V[k, 0], V[k, 1], V[k, 2]
        if k + 1 <= k_prev:
            bx, by, bz = V[k + 1, 0], V[k + 1, 1], V[k + 1, 2]
        else:  # the segment holding P_{i-1}: only its part behind P_{i-1}
            bx, by, bz = px, py, pz
        dx, dy, dz = bx - ax, by - ay, bz - az
        wx, wy, wz = ax - px, ay - py, az - pz
        A = dx * dx + dy * dy + dz * dz
        B = wx * dx + wy * dy + wz * dz
        C = wx * wx + wy * wy + wz * wz - L2
        disc = B * B - A * C
        if disc < 0.0:
            disc = 0.0
        root = math.sqrt(disc)
        if C >= 0.0:
            # f(0) = C >= 0 > f(1): the one root in [0, 1) is the smaller one (stable form)
            den = root - B
            t = C / den if den > 0.0 else 0.0
        else:
            # V[0] itself inside the sphere: extrapolate the first segment's line backwards
            t = (-B - root) / A if A > 0.0 else 0.0
            overruns += 1
        qx, qy, qz = ax + t * dx, ay + t * dy, az + t * dz
        # unit tangent of the segment (direction of travel)
        if k + 1 <= k_prev:
            tx, ty, tz = dx, dy, dz
        elif k + 1 <= n - 1:
            tx, ty, tz = V[k + 1, 0] - ax, V[k + 1, 1] - ay, V[k + 1, 2] - az
        else:
            tx, ty, tz = dx, dy, dz
        tn = math.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx / tn, ty / tn, tz / tn
        cx, cy, cz = qx - px, qy - py, qz - pz
        num = cx * vx + cy * vy + cz * vz
        den = cx * tx + cy * ty + cz * tz
        if abs(den) < SINGULAR_COS * L:
            sdot = 0.0
            singular += 1
        else:
            sdot = num / den
        vx, vy, vz = tx * sdot, ty * sdot, tz * sdot
        pts[i, 0], pts[i, 1], pts[i, 2] = qx, qy, qz
        vel[i, 0], vel[i, 1], vel[i, 2] = vx, vy, vz
        seg[i] = k
        par[i] = t
        ptr[i] = k
        k_prev = k
        px, py, pz = qx, qy, qz
    stats[0] = iters
    stats[1] = overruns
    stats[2] = singular


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
        self._n = m + 1
        # joint i (1-based) sits on vertex m - i: the segment starting there, parameter 0
        self.ptr = np.array([m - i for i in range(1, m)], dtype=np.int64)
        self.pts = bb[1:].copy()  # never a view of the caller's array
        self.vel = np.zeros((m - 1, 3))
        self.seg = self.ptr.copy()
        self.par = np.zeros(m - 1)
        self.stats = np.zeros(3, dtype=np.int64)
        self.total_iterations = 0
        self.overruns = 0
        self.singular = 0

    # ---- storage -------------------------------------------------------
    @property
    def n_points(self) -> int:
        """Number of recorded vertices (extension end and initial backbone included)."""
        return self._n

    @property
    def points(self) -> NDArray[np.float64]:
        """Copy of the recorded vertices (n, 3) [m], oldest first."""
        return self._V[: self._n].copy()

    @property
    def arc_length(self) -> NDArray[np.float64]:
        """Copy of the cumulative arc length at each vertex (n,) [m], 0 at the extension's end."""
        return self._S[: self._n].copy()

    @property
    def length(self) -> float:
        """Total arc length of the recorded polyline [m] (extension included)."""
        return float(self._S[self._n - 1])

    @property
    def capacity(self) -> int:
        """Current number of vertex slots."""
        return self._V.shape[0]

    @property
    def last_iterations(self) -> int:
        """Pointer moves made by the last :meth:`chain` call (all joints together)."""
        return int(self.stats[0])

    def ensure_capacity(self, extra: int = 1) -> None:
        """Grow (double) the vertex arrays so ``extra`` more vertices fit."""
        need = self._n + extra
        if need <= self._V.shape[0]:
            return
        cap = self._V.shape[0]
        while cap < need:
            cap *= 2
        V = np.zeros((cap, 3))
        S = np.zeros(cap)
        V[: self._n] = self._V[: self._n]
        S[: self._n] = self._S[: self._n]
        self._V, self._S = V, S

    # ---- API -----------------------------------------------------------
    def record(self, x_tip: ArrayLike) -> bool:
        """Record the desired tip position ``x_tip`` [m]; True if it became a new vertex."""
        x = _vec3(x_tip, "x_tip")
        self.ensure_capacity(1)
        n = record_into(self._V, self._S, self._n, x, self.spacing)
        added = n != self._n
        self._n = n
        return added

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
        self._chain(x, xd)
        return self.pts.copy(), self.vel.copy()

    def _chain(self, x: NDArray[np.float64], xd: NDArray[np.float64]) -> None:
        chain_into(self._V, self._n, x, xd, self.link_length, self.ptr, self.pts, self.vel, self.seg,
                   self.par, self.stats)
        self._account()

    def _account(self) -> None:
        """Accumulate the counters of the last chain evaluation."""
        self.total_iterations += int(self.stats[0])
        self.overruns += int(self.stats[1])
        self.singular += int(self.stats[2])

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
        if joint is None:
            return float(full_distance(self._V, self._n, x))
        if not 1 <= joint <= self.n_joints:
            raise ValueError(f"joint must be in 1..{self.n_joints} (J1 nearest the tip), got {joint}")
        if not (np.isfinite(window) and window >= 0):
            raise ValueError(f"window must be a non-negative length [m], got {window}")
        i = joint - 1
        return float(window_distance(self._V, self._S, self._n, x, int(self.seg[i]), float(self.par[i]),
                                     float(window)))

    def max_deviation(self, points: ArrayLike, window: float = 0.02) -> float:
        """Largest windowed :meth:`distance_to_path` of J1..J_{m-1} ``points`` (m-1, 3) [m].

        This is the per-step term of the ``slither_deviation_max`` metric.
        """
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape != (self.n_joints, 3):
            raise ValueError(f"points must have shape ({self.n_joints}, 3) (J1 first), got {pts.shape}")
        return max(self.distance_to_path(pts[i], joint=i + 1, window=window) for i in range(self.n_joints))
