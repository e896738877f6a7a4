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

Cost: one scan of the 27 buckets around the point per pass tested, O(points in them).
"""

from __future__ import annotations

import math

import numba

__all__ = ["beside_a_line"]


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
