"""Does a ray that passed a sensed point without a hit say that the surface there is gone?

The map forgets a point when rays pass cleanly near it (:mod:`navstack.planner.map`, "Forgetting"): within
1 cm, growing by 0.12 m per m along the ray, because the forward rays lie centimetres apart and a door's face
that slid away must go, not only the few points that lay right on a ray. That reasoning holds for a surface
the ray *crosses*: had the door still been there, a ray through its plane within that radius of a point of it
would have hit it. It fails for a surface the ray runs *along*: a ray 2 cm beside a 2 mm plate seen edge-on,
or beside a rod, passes the plate's sensed points as closely, and says nothing about the plate. The reviewers'
``edge_plate_channel`` world showed it: once its map forgot (after a wait, boxed in), rays running beside the
plate erased it, and the body struck it (seeds 0 and 2: -5.8 and -0.6 mm).

The test here tells the two apart from the map's own points, seen along the ray. The point's neighbours
(surface points within ``radius``, shadows left out) are projected onto the plane across the ray. A surface
the ray crosses spreads there both ways (a door's face seen face-on); a surface the ray runs along, or a rod
or an edge across it, projects to a line, and a rod or an edge along the ray to a spot. When the projection
is a line (its smaller spread below ``line_ratio`` times the larger, in standard deviations) and the ray passes
more than ``across`` [m] from it, or when it is a spot (spread under 5 mm, in standard deviation) the ray
passes more than ``across`` from, the ray ran beside the surface, and its pass is not
counted against the point. A point with fewer than ``min_points`` neighbours (a sparsely sensed face, a lone
hit) keeps the plain rule: the pass counts. The map asks only about passes in the cone's reach beyond
``across`` (its base radius, ``sensed_clear_radius``, 1 cm, once motion is sensed or a wait has begun
forgetting): a ray that passes a point closer than that counts whatever the point lies on, and a map that
does not forget, or forgets from the start (``forget_moved``: 4 mm, no cone), tests no pass.

The map's motion detector asks a second question of its own (:func:`along_a_plane`): does a ray run along the
plane a point's neighbours make? A ray 1-4 mm off a plate's face, at a degree or so to it, passes within the
detector's 4 mm of the face's sensed points (each uncertain by a millimetre or so), and says nothing about the
plate: at less than ``MapConfig.motion_graze_angle`` (10 deg) to that plane its pass is no contradiction
(:mod:`navstack.planner.map`, "False alarms").

Cost: one scan of the 27 buckets around the point per pass tested, O(points in them).
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["along_a_plane", "beside_a_line"]


@numba.njit(cache=True)
def beside_a_line(q, i, j, k, lx, ly, lz, dx, dy, dz, across, radius, min_points, line_ratio, P, alive, shadow,
                  head, nxt, dims, mark, tag):  # pragma: no cover - jitted
    """Whether the ray along the unit ``(dx, dy, dz)`` runs beside the surface that point ``q`` (in bucket
    ``(i, j, k)``, of a grid ``dims`` whose buckets are at least ``radius`` wide) lies on, rather than through it.

    ``(lx, ly, lz)``: the point minus the ray's closest point to it [m].  The point's live non-shadow
    neighbours within ``radius`` [m] (itself among them unless it is a shadow; at least ``min_points`` of them,
    else False) are projected onto the plane across the ray.  True when they lie along a line there (smaller
    standard deviation below ``line_ratio`` times the larger) and the ray passes more than ``across`` [m] from
    it; and when they lie around one spot there (standard deviation under 5 mm: a line along the ray) and the
    ray passes more than ``across`` from their centroid.
    ``head`` / ``nxt``: the buckets' linked lists of points (:class:`~navstack.planner.map.SensedMap`).  A
    neighbour this ray's pass has removed (``mark[p] == tag``) still counts: the answer does not depend on the
    order the pass takes the points in.
    """
    # two unit axes across the ray: a = (e_x or e_y) x d, b = d x a
    if abs(dx) < 0.9:
        ax, ay, az = 0.0, -dz, dy
    else:
        ax, ay, az = dz, 0.0, -dx
    s = math.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / s, ay / s, az / s
    bx, by, bz = dy * az - dz * ay, dz * ax - dx * az, dx * ay - dy * ax
    px, py, pz = P[q, 0], P[q, 1], P[q, 2]
    n = 0
    s1 = s2 = s11 = s12 = s22 = 0.0
    r2 = radius * radius
    for a in range(max(i - 1, 0), min(i + 2, dims[0])):
        for b in range(max(j - 1, 0), min(j + 2, dims[1])):
            for c in range(max(k - 1, 0), min(k + 2, dims[2])):
                p = head[a, b, c]
                while p >= 0:
                    if (alive[p] or mark[p] == tag) and not shadow[p]:  # live before this ray's pass
                        vx, vy, vz = P[p, 0] - px, P[p, 1] - py, P[p, 2] - pz
                        if vx * vx + vy * vy + vz * vz < r2:
                            u1 = vx * ax + vy * ay + vz * az
                            u2 = vx * bx + vy * by + vz * bz
                            n += 1
                            s1 += u1
                            s2 += u2
                            s11 += u1 * u1
                            s12 += u1 * u2
                            s22 += u2 * u2
                    p = nxt[p]
    if n < min_points:
        return False
    m1, m2 = s1 / n, s2 / n
    # the ray's place across itself, from the neighbours' centroid: -(l1, l2) - (m1, m2)
    r1 = -(lx * ax + ly * ay + lz * az) - m1
    r2 = -(lx * bx + ly * by + lz * bz) - m2
    c11, c12, c22 = s11 / n - m1 * m1, s12 / n - m1 * m2, s22 / n - m2 * m2
    mid = 0.5 * (c11 + c22)
    disc = math.sqrt(max(0.25 * (c11 - c22) ** 2 + c12 * c12, 0.0))
    big, small = mid + disc, mid - disc
    if big < 0.005**2:  # one spot across the ray: a line along it
        return r1 * r1 + r2 * r2 > across * across
    if small > line_ratio * line_ratio * big:
        return False  # spread both ways across the ray: a surface the ray crosses
    # the line's direction across the ray (the larger spread's eigenvector), and its normal
    if c11 >= c22:  # of the eigenvector's two forms, the one without cancellation (never zero here)
        e1, e2 = big - c22, c12
    else:
        e1, e2 = c12, big - c11
    s = math.sqrt(e1 * e1 + e2 * e2)
    return abs(r2 * e1 - r1 * e2) > across * s  # the ray's distance from the line, times |e| = s


@numba.njit(cache=True)
def along_a_plane(q, i, j, k, dx, dy, dz, sin_min, radius, min_points, plane_ratio, P, alive, shadow, head, nxt,
                  dims):  # pragma: no cover - jitted
    """Whether the ray along the unit ``(dx, dy, dz)`` runs along the plane that point ``q``'s neighbours make,
    at less than ``asin(sin_min)`` to it: a plate's face seen edge-on, which a sensed point's millimetres of
    error put within reach of a ray running just outside it.

    The neighbours: live non-shadow points within ``radius`` [m] of ``q`` (in bucket ``(i, j, k)`` of a grid
    ``dims`` whose buckets are at least ``radius`` wide), at least ``min_points`` of them (else False).  They
    make a plane when their smallest spread (standard deviation, across the plane) is below ``plane_ratio``
    times the middle one, and the middle one is 5 mm or more (not a rod or an edge).
    """
    px, py, pz = P[q, 0], P[q, 1], P[q, 2]
    n = 0
    s = np.zeros(3)
    ss = np.zeros((3, 3))
    r2 = radius * radius
    for a in range(max(i - 1, 0), min(i + 2, dims[0])):
        for b in range(max(j - 1, 0), min(j + 2, dims[1])):
            for c in range(max(k - 1, 0), min(k + 2, dims[2])):
                p = head[a, b, c]
                while p >= 0:
                    if alive[p] and not shadow[p]:
                        v0, v1, v2 = P[p, 0] - px, P[p, 1] - py, P[p, 2] - pz
                        if v0 * v0 + v1 * v1 + v2 * v2 < r2:
                            n += 1
                            v = (v0, v1, v2)
                            for e in range(3):
                                s[e] += v[e]
                                for f in range(3):
                                    ss[e, f] += v[e] * v[f]
                    p = nxt[p]
    if n < min_points:
        return False
    m = s / n
    cov = ss / n - np.outer(m, m)
    w, vec = np.linalg.eigh(cov)  # ascending
    if w[1] < 0.005**2 or w[0] >= plane_ratio * plane_ratio * w[1]:
        return False  # a rod, an edge or a spot; or a curved surface: no plane
    return abs(dx * vec[0, 0] + dy * vec[1, 0] + dz * vec[2, 0]) < sin_min
