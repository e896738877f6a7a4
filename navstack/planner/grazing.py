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
or an edge, projects to a line. When the projection is a line (its smaller spread below ``line_ratio`` times
the larger, in standard deviations) and the ray passes more than ``across`` [m] from that line, the ray ran
beside the surface, and its pass is not counted against the point. A point with fewer than ``min_points``
neighbours (a sparsely sensed face, a lone hit) keeps the plain rule: the pass counts. The map asks only about
passes in the cone's reach beyond ``across`` (its base radius, 1 cm once forgetting): a ray that passes a
point closer than that counts whatever the point lies on, and before the map forgets (4 mm, no cone) no pass
is tested, so a static world pays nothing for it.

Cost: one scan of the 27 buckets around the point per pass tested, O(points in them).
"""

from __future__ import annotations

import math

import numba

__all__ = ["beside_a_line"]


@numba.njit(cache=True)
def beside_a_line(q, i, j, k, lx, ly, lz, dx, dy, dz, across, radius, min_points, line_ratio, P, alive, shadow,
                  head, nxt, dims):  # pragma: no cover - jitted
    """Whether the ray along the unit ``(dx, dy, dz)`` runs beside the surface that point ``q`` (in bucket
    ``(i, j, k)``, of a grid ``dims`` whose buckets are at least ``radius`` wide) lies on, rather than through it.

    ``(lx, ly, lz)``: the point minus the ray's closest point to it [m].  The point's live non-shadow
    neighbours within ``radius`` [m] (itself among them; at least ``min_points`` of them, else False) are
    projected onto the plane across the ray; True when they lie along a line there (smaller standard deviation
    below ``line_ratio`` times the larger, the larger at least 5 mm) and the ray passes more than ``across``
    [m] from it.  ``head`` / ``nxt``: the buckets' linked lists of points (:class:`~navstack.planner.map.SensedMap`).
    """
    # two unit axes across the ray: a = d x (e_x or e_z), b = d x a
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
                    if alive[p] and not shadow[p]:
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
    c11, c12, c22 = s11 / n - m1 * m1, s12 / n - m1 * m2, s22 / n - m2 * m2
    mid = 0.5 * (c11 + c22)
    disc = math.sqrt(max(0.25 * (c11 - c22) ** 2 + c12 * c12, 0.0))
    big, small = mid + disc, mid - disc
    if big < 0.005**2 or small > line_ratio * line_ratio * big:
        return False  # no extent, or spread both ways across the ray: a surface the ray crosses
    # the line's direction across the ray (the larger spread's eigenvector), and its normal (n1, n2)
    if c11 >= c22:  # of the eigenvector's two forms, the one without cancellation (never zero here)
        e1, e2 = big - c22, c12
    else:
        e1, e2 = c12, big - c11
    s = math.sqrt(e1 * e1 + e2 * e2)
    n1, n2 = -e2 / s, e1 / s
    # the ray's place across itself, from the neighbours' centroid: -(l1, l2) - (m1, m2)
    l1 = lx * ax + ly * ay + lz * az
    l2 = lx * bx + ly * by + lz * bz
    return abs((l1 + m1) * n1 + (l2 + m2) * n2) > across
