"""The planner's local map: the surfaces it has sensed, and the space it has seen to be free.

Built from filtered tip-sensor readings only (:class:`navstack.estimate.RangeEstimate`) and the
tip's own motion; it never reads obstacle geometry.  Two layers over one bounded region (a box
around the start and the goals, ``margin`` beyond them), in the world frame, metres:

**Surface points.**  Each hit of a ray that was measured in this reading is merged into a
voxel of side ``voxel`` (a running mean over at most ``average`` samples: the range noise
averages out) and becomes one surface point.  The points are indexed in a dense grid of
buckets of side ``bucket`` (a multiple of ``voxel`` on the same lattice, so a point never
leaves its bucket), which answers "the nearest surface point within ``r <= bucket``" exactly
by scanning 27 buckets: :func:`nearest_distance`.

**Seen free.**  A cell (side ``free_cell``) is *seen free* once a ray has passed through it
without a hit (up to ``hit_backoff`` before the hit, or the whole ray for a miss), or once the
tip has been there.  Unseen space is not an obstacle (the planner is optimistic about what it
has not seen), but unseen space *next to a sensed surface* is probably more of that surface:
the rays sample a wall a few centimetres apart, and the gaps between the samples are not
openings until a ray has gone through them (see :mod:`navstack.planner.potential`).

**Forgetting**: surfaces that move (spec 2b) must not stay in the map where they were.  Each point
carries evidence, as an occupancy map's log-odds: ``initial_evidence`` when first seen, one more per
further hit (up to ``max_evidence``), one less each time a ray passes cleanly through it (within
``clear_radius`` of its line, well before the ray's own end); at zero it is removed.  Removing a point at
the first clean pass instead erased the noisy samples of static surfaces that rays graze (measured on a
slot rack: the tip kept re-entering a gap whose sides had been erased, 60 s timeout, against 22.6 s
without erasing); a static surface keeps being hit, and keeps its points.  Even so, forgetting in a static
world costs more than it buys (a hard sparse truss: reached in 36.5 s without, timeout with), so the map
forgets only once it has **sensed motion** (``detect_motion``), or from the start with ``forget_moved``.

**Sensing motion** (``detect_motion``): until then the clean passes change nothing the planner sees. Each point
keeps its *latent* evidence, what forgetting would have left it (one less per clean pass, one more per hit, put back
at ``initial_evidence`` by a hit once exhausted). A clean pass is a *contradiction* of an *established* point (at
``max_evidence``: hit again and again) once the passes have used its latent evidence up (forgetting from the start
would have removed it), and only when the ray comes from within ``motion_view_angle`` (30 deg) of the direction the
point was sensed from (the running mean of its hits' unit directions, shorter when they spread: then a ray must come
closer to it, and a point hit alternately from 35 deg either side is contradicted by none) and does not run
along the plane the point's neighbours make (at less than ``motion_graze_angle``, 10 deg:
:func:`~navstack.planner.grazing.along_a_plane`), each point once per reading (false alarms, below). When
``motion_contradictions`` of them fall within the last ``motion_window`` readings (a surface seen for a while, and
then seen through, again and again), that is motion: the map forgets from then on, for good; the latent evidence
becomes the evidence, and the points forgetting would have removed go at once. Without it the points hit while the
obstacle moved, before motion was sensed, stayed: in the tests' door world the trial failed on seeds 0-2 (3 of 5
reached with forgetting from the start, 0 of 5 without the latent evidence); with it all five ended exactly as with
forgetting from the start (the same steps and clearance). Since the false-alarm conditions all five reach the goal
(seeds 2 and 4 later), four with forgetting from the start. Once motion is sensed, a clean pass counts within
``sensed_clear_radius`` (1 cm) instead of ``clear_radius``: the tip's forward rays lie 2-7 cm apart where a door's
face was, and at 4 mm most of the face stayed in the map for good (a review's sliding door: 191 stale points 16 s
after it had gone; the planner stalled boxed in at 4 of 9 seeds, and reached the goal at all 9 with the wider
radius), and the radius grows along the ray by ``sensed_clear_slope`` (0.12 m per m): a tip that holds still in
front of a window, waiting for its door to open, kept 326 of the door's points between its rays with a fixed 1 cm,
and 29 with the cone (``sliding-door`` seed 653817592: reached after waiting, stalled before). The door world then
differs from forgetting from the start (26.0 s against 25.9 s, both reached). A planner boxed in by what its map
holds may also turn forgetting on (:meth:`SensedMap.begin_forgetting`): a door seen only while it moved is never
established, so never contradicted; it ends once the planner has a way on again (below). No one tells the map
whether the world holds moving obstacles (spec 2b).

**False alarms.** Static worlds do contradict established points, where rays graze a surface (a sensed point
is a running mean of hits, uncertain by millimetres along the direction it was sensed from, and inside a curved
surface: a ray running just outside the surface passes within ``clear_radius`` of it). When every clean pass of
an established point counted, 59 static trials (48 generated, 11 example worlds) gave at most 59 in 30
readings, and a sphere leaving a door (the tests' door world) up to 280; the threshold, 150, was set at 2.5
times that static maximum. It was no bound: worlds written by reviewers sensed motion that was not there in 9
of 24 trials (8 worlds, seeds 0-2: rays through a 4 mm plate's window or slot passing its rim, rays along a
plate seen edge-on), and so did one generated sparse truss (rays tangent to a member), and the map then forgot
static structure (a collision, ``edge_plate_channel`` at seed 1685456953). Counted there, the contradicted
points were few (11 in the sparse truss), passed reading after reading while being hit again in between (a
rim), or passed from across the direction they were sensed from (median 68 deg in the sparse truss, 60 deg at
the slots' rims), while the door's sphere is seen through from where it was seen (at most 15 deg, 19 deg for a
generated sliding door). With the two conditions above, the same 86 static trials (43 worlds, seeds 0 and 1)
give at most 45 in 30 readings and none senses motion, the door's sphere still reaches 202-247 (detection
off) and is sensed 1.5 s later than before (readings 390 and 383 against 345 and 326, both seeds reached);
the latent condition alone left a static maximum of 112, the angle alone 85. The two left one false alarm on
those worlds: the plate seen edge-on at seed 1685456953 reached 150 at reading 1907 (rays running along its
face, 1-4 mm off it at a median 1 deg, past points sensed from 14 deg off it, within the angle). A ray at less
than 10 deg to the plane of the point's neighbours is no contradiction now (through the door's sphere the rays
met its surface at 18 deg or more): that trial stays at 34, the 86 at 45 as before, and the door's sphere is
sensed at the same readings. Those tests run after the rays, on the reading's candidates (:func:`_judge`).

**Forgetting a static world.** Before those conditions, a 2 mm plate seen edge-on, the tip level with its plane so
that its rays run along the face sensed earlier from the side, gave 150 in 30 readings at reading 1620 of a review
world's trial (``edge_plate_channel``, seed 0: its readings replayed into a map that no wait turned forgetting on),
and that map then lost the plate's edge within 200 readings (85 points near it, then 3). In the trial itself a wait
had turned forgetting on at reading 671, with the same end: its cone erased the edge, and the body struck the plate
(the README's margins paragraph). Two rules came of it. The forgetting a wait begins ends with the wait
(:meth:`SensedMap.end_forgetting`, called by the planner once it has a way on): a static world is mapped as static
again, and the map senses motion afresh. And a pass counts against a point only if it does not run beside the line
the point's neighbours make, seen along the ray (``sheet_radius``, :mod:`navstack.planner.grazing`): rays running
beside a plate seen edge-on, or a rod, do not erase it. On 12 trials of that world (seeds 0-3, and 8 seeds of
``--count 8 --seed 77``) the two took it from 3 goals reached, 5 collisions and 4 stalls to 5 reached, 1 collision
and 6 stalls (the first alone: 7 reached, 2 collisions and 3 stalls: the grazing rule keeps more of what was sensed,
and stalls more). The grazing rule tests only passes beyond the base radius ``sensed_clear_radius`` (in the cone),
so a map that does not forget, or forgets from the start (``forget_moved``, no cone), pays nothing for it. It keeps
only what was sensed densely enough: on the first trial's recorded readings the plate's edge still went (85 points
near it, then 3), each of its last points alone within 3 cm, with no line to tell (``sheet_min_points``).

Cost: one update per control step, O(rays x range / free_cell) cell writes; queries O(27 x
points per bucket).  Every kernel is ``numba.njit``.  Sensing motion runs the clean-pass test on every
reading, static worlds too: the update went from 0.036-0.055 to 0.091-0.145 ms per control step
(``tools/bench_stages.py``: paper demo, ``truss_clutter.json``, slot-rack seed 5); scanning each bucket
once per ray, and only those within the clear radius of the ray (not all 27 around each bucket it crosses),
brought it to 0.083-0.100 ms, the same answers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.planner.grazing import along_a_plane, beside_a_line
from navstack.validate import flag, in_range, integer, is_number, positive

__all__ = ["MapConfig", "SensedMap", "nearest_distance"]


@dataclass(frozen=True)
class MapConfig:
    """Resolution and extent of :class:`SensedMap` (metres).

    Attributes:
        voxel: side of the voxels hits are merged in.
        bucket: side of the index buckets; queries look this far at most (a multiple of ``voxel``).
        free_cell: side of the seen-free cells.
        free_cell_fallback: ``free_cell`` is a finer grid than this one, used only while the box needs at most
            :data:`FINE_CELLS` of them; else cells of ``free_cell_fallback / j`` for the largest whole ``j`` that
            fits, down to ``free_cell_fallback`` itself (``TrialConfig.for_robot`` sets it for a thinner robot: a wide
            world keeps coarser cells, as the navigation function's cost grows with their number); ``None``: no
            fallback (a box of more than :data:`MAX_FREE_CELLS` cells is refused).
        margin: the map covers the box around the start and the goals grown by this.
        average: samples in a voxel's running mean.
        hit_backoff: a ray that hits marks free space only up to this before its hit.
        forget_moved: rays that pass through stored points count against them from the start (moving obstacles
            known beforehand); without it they do once motion is sensed (``detect_motion``).
        detect_motion: count the clean passes through established points (at ``max_evidence``) whose latent
            evidence they have used up, and forget once ``motion_contradictions`` of them fall within
            ``motion_window`` readings (module docstring, "Sensing motion").
        motion_contradictions: contradictions (an established point passed cleanly through, each point
            counted at most once per reading) within ``motion_window`` readings that mean motion.
        motion_window: readings [count; one per control step, 30 per second] the contradictions are summed over.
        initial_evidence, max_evidence: a new point holds ``initial_evidence``, each further hit one more
            (up to ``max_evidence``), each clean pass of a ray one less; at zero it is removed.
        shadow_depths: depths behind each hit [m] where shadow points are put (empty: none).
        clear_radius: with ``forget_moved``, a ray passing this close to a stored point, before its own
            end, removes it.
        clear_backoff: ... but only a point this far or more before the ray's end.
        sensed_clear_radius: once motion is sensed (``detect_motion``), the clean-pass radius instead of
            ``clear_radius``: the forward rays lie 2-7 cm apart 0.2 m ahead, so a 4 mm radius leaves most of a
            surface that moved away (a door's face) in the map for good (sliding_door.json: 191 stale points,
            68 at full evidence, 16 s after the door had gone; the planner stalled boxed in).
        sensed_clear_slope: once motion is sensed, the clean-pass radius grows by this much per metre along the
            ray (a cone, half the forward rings' 0.23 rad spacing): a tip that holds still, waiting for a door
            to open, sees the whole window clear, not only the lines its rays take.
        sheet_radius: a clean pass in the cone beyond ``sensed_clear_radius`` (once motion is sensed, or a wait
            has begun forgetting) is tested against the surface its point lies on, as the point's neighbours within
            ``sheet_radius`` show it (:mod:`navstack.planner.grazing`): a ray that runs beside a plate seen edge-on,
            or a rod, is no clean pass of it. 0: no test (every pass within the radius counts). At most
            ``bucket``.
        sheet_min_points: fewer neighbours than this (the point itself counted) show no surface: the pass counts.
        sheet_line_ratio: the neighbours, seen along the ray, lie along a line when the smaller standard deviation
            of their spread is below this times the larger.
        motion_view_angle: a clean pass counts as a contradiction only when its ray is within this angle [rad] of
            the direction the point was sensed from (the running mean of its hits' unit directions, shorter when
            they spread; a point added without a direction, by :meth:`SensedMap.add_points`, from any direction).
        motion_graze_angle: ... and not when its ray meets the plane of the point's neighbours (within
            ``sheet_radius``, ``sheet_min_points`` of them, flat by ``sheet_line_ratio``, and spread 5 mm or more
            (standard deviation) in the plane both ways) at less than this [rad]
            (:func:`~navstack.planner.grazing.along_a_plane`; 0: no such test).
    """

    voxel: float = 0.01
    bucket: float = 0.04
    free_cell: float = 0.02
    free_cell_fallback: float | None = None
    margin: float = 0.7
    average: int = 8
    hit_backoff: float = 0.03
    clear_radius: float = 0.004
    clear_backoff: float = 0.05
    sensed_clear_radius: float = 0.01
    sensed_clear_slope: float = 0.12
    forget_moved: bool = False
    detect_motion: bool = True
    motion_contradictions: int = 150
    motion_window: int = 30
    initial_evidence: int = 2
    max_evidence: int = 6
    shadow_depths: tuple[float, ...] = (0.015, 0.03, 0.045)
    sheet_radius: float = 0.03
    sheet_min_points: int = 4
    sheet_line_ratio: float = 0.25
    motion_view_angle: float = math.radians(30.0)
    motion_graze_angle: float = math.radians(10.0)

    def __post_init__(self) -> None:
        positive(self, "voxel", "bucket", "free_cell", "margin", "hit_backoff", "clear_radius", "clear_backoff",
                 "sensed_clear_radius")
        if self.free_cell_fallback is not None:
            positive(self, "free_cell_fallback")
        in_range(self, "sensed_clear_slope", lo=0.0, hi=1.0, hi_open=True, unit=" [m/m]")
        ratio = self.bucket / self.voxel
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"MapConfig.bucket ({self.bucket}) must be a whole multiple of voxel ({self.voxel})")
        depths = self.shadow_depths
        if not isinstance(depths, tuple) or not all(is_number(x) and 0 < x < math.inf for x in depths):
            raise ValueError(f"MapConfig.shadow_depths must be a tuple of positive lengths [m], got {depths!r}")
        flag(self, "forget_moved", "detect_motion")
        in_range(self, "sheet_radius", lo=0.0, hi=self.bucket, unit=" [m] (at most bucket)")
        in_range(self, "motion_view_angle", lo=0.0, hi=math.pi, unit=" [rad]")
        in_range(self, "motion_graze_angle", lo=0.0, hi=math.pi / 2, unit=" [rad]")
        in_range(self, "sheet_line_ratio", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
        integer(self, "average", "initial_evidence", "max_evidence", "motion_contradictions", "motion_window",
                "sheet_min_points", lo=1)


# ------------------------------------------------------------------------------------------ kernels
@numba.njit(cache=True, inline="always")
def _cell(x, origin, size, dims, k):  # pragma: no cover - jitted
    i = int(math.floor((x - origin[k]) / size))
    if i < 0:
        return 0
    if i >= dims[k]:
        return dims[k] - 1
    return i


@numba.njit(cache=True)
def nearest_distance(px, py, pz, r, P, alive, head, nxt, origin, bucket, dims):  # pragma: no cover
    """Distance [m] from (px, py, pz) to the nearest live point, exact if below ``r``, else ``r``.

    Scans the buckets within ``r`` (27 when ``r <= bucket``).
    """
    bx = _cell(px, origin, bucket, dims, 0)
    by = _cell(py, origin, bucket, dims, 1)
    bz = _cell(pz, origin, bucket, dims, 2)
    m = int(math.ceil(r / bucket))
    best = r * r
    for i in range(max(bx - m, 0), min(bx + m + 1, dims[0])):
        for j in range(max(by - m, 0), min(by + m + 1, dims[1])):
            for k in range(max(bz - m, 0), min(bz + m + 1, dims[2])):
                q = head[i, j, k]
                while q >= 0:
                    if alive[q]:
                        dx = P[q, 0] - px
                        dy = P[q, 1] - py
                        dz = P[q, 2] - pz
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 < best:
                            best = d2
                    q = nxt[q]
    return math.sqrt(best)


@numba.njit(cache=True)
def _pass_bucket(i, j, k, ray, s0, s1, clear_r, slope, P, alive, evidence, latent, mark, tag, head, nxt, forget,
                 established, seen, reading, shadow, dims, sheet, cand, n_cand):  # pragma: no cover - jitted
    """A clean pass of the ray ``ray = (ox, oy, oz, dx, dy, dz)`` between ``s0`` and ``s1`` through the live
    points of bucket (i, j, k) within ``clear_r + slope a`` of its line, ``a`` [m] along the ray.

    ``forget``: one less evidence each, once per ray (``mark[q] == tag`` once counted for the ray ``tag``: the DDA
    visits a bucket up to 27 times); a point out of evidence is removed.  Otherwise the evidence stays, each point
    loses one ``latent`` evidence (what forgetting would have left) once per ray, and a point at ``established``
    evidence whose latent evidence is used up, not yet counted in this reading (``seen[q] != reading``), is a
    candidate contradiction: ``(q, tag)`` goes into ``cand[n_cand[0]]`` for :func:`_judge` (when it is full, it
    counts at once).
    With ``sheet = (radius, min_points, line_ratio)``, a pass farther than ``clear_r`` from a point (in the cone)
    does not count when it runs beside the line the point's neighbours make across the ray
    (:func:`~navstack.planner.grazing.beside_a_line`); a closer pass always counts.  ``sheet=None``: every pass
    counts, and numba compiles that case without the test (its branch pruned): a kernel holding the test, even never
    reached, made every map update 3.2-3.7x slower (62 -> 200-228 us on the tests' recorded ``truss_clutter``
    readings).  Returns ``(removed, contradicted)``."""
    ox, oy, oz, dx, dy, dz = ray
    removed = 0
    contradicted = 0
    q = head[i, j, k]
    while q >= 0:
        if alive[q]:
            wx = P[q, 0] - ox
            wy = P[q, 1] - oy
            wz = P[q, 2] - oz
            a = wx * dx + wy * dy + wz * dz
            if s0 < a < s1:
                lx = wx - a * dx
                ly = wy - a * dy
                lz = wz - a * dz
                r = clear_r + slope * a
                d2 = lx * lx + ly * ly + lz * lz
                counts = d2 < r * r
                if sheet is not None:  # pruned when None
                    if counts and d2 >= clear_r * clear_r:  # in the cone beyond clear_r: not beside a line
                        counts = not beside_a_line(q, i, j, k, lx, ly, lz, dx, dy, dz, clear_r, sheet[0], sheet[1],
                                                   sheet[2], P, alive, shadow, head, nxt, dims, mark, tag)
                if counts:
                    if not forget:
                        if mark[q] != tag:
                            mark[q] = tag
                            latent[q] -= 1
                        if evidence[q] >= established and latent[q] <= 0 and seen[q] != reading:
                            c = n_cand[0]
                            if c < cand.shape[0]:  # a candidate, for :func:`_judge` after the rays
                                cand[c, 0] = q
                                cand[c, 1] = tag
                                n_cand[0] = c + 1
                            else:  # no room left: it counts
                                seen[q] = reading
                                contradicted += 1
                    elif mark[q] != tag:
                        mark[q] = tag
                        evidence[q] -= 1
                        if evidence[q] <= 0:
                            alive[q] = False
                            removed += 1
        q = nxt[q]
    return removed, contradicted


@numba.njit(cache=True)
def _dda_start(p, d, idx, origin, bucket, step, tmax, tdelta):  # pragma: no cover - jitted
    """Set the 3D DDA's per-axis ``step``, ``tmax`` and ``tdelta`` (each (3,), written in place) for a ray from
    ``p`` along ``d`` starting in bucket ``idx`` (Amanatides and Woo 1987)."""
    for c in range(3):
        step[c] = 0
        tmax[c] = np.inf
        tdelta[c] = np.inf
        if d[c] > 1e-12:
            step[c] = 1
            tmax[c] = (origin[c] + (idx[c] + 1) * bucket - p[c]) / d[c]
            tdelta[c] = bucket / d[c]
        elif d[c] < -1e-12:
            step[c] = -1
            tmax[c] = (origin[c] + idx[c] * bucket - p[c]) / d[c]
            tdelta[c] = -bucket / d[c]


@numba.njit(cache=True)
def _pass_along(ray, s0, s1, clear_r, slope, P, alive, evidence, latent, mark, tag, head, visit, nxt, origin, bucket,
                dims, forget, established, seen, reading, shadow, sheet, cand, n_cand, work,
                dwork, near):  # pragma: no cover - jitted
    """The clean pass of ``ray = (ox, oy, oz, dx, dy, dz)`` over [s0, s1] through the points within
    ``clear_r + slope a`` of it, ``a`` along the ray (:func:`_pass_bucket`).  A 3D DDA (Amanatides and Woo
    1987) walks the buckets the segment crosses; in each, the buckets that the box around the segment's part
    there, grown by the radius at its far end, touches are scanned, each once per ray (``visit[bucket] == tag``
    once scanned; an empty bucket is skipped, unmarked).  Every point within that radius of the segment lies in
    one of them (a point stays in the voxel, so the bucket, it was first put in).  ``near`` (the bucket grid)
    is 1 where one of the 27 buckets round a bucket ever held a point (:func:`_merge_points` keeps it): where it
    is 0 the walk steps on without working out the box.  ``work`` (3, 3) int and
    ``dwork`` (2, 3) float are the DDA's scratch space, passed in so that a reading's rays share one allocation
    (each ray allocating its five 3-vectors cost a tenth of :func:`_carve` on the paper demo's readings).
    Returns ``(removed, contradicted)``."""
    removed = 0
    contradicted = 0
    grazing = sheet[0] > 0.0 and slope > 0.0  # the test can only apply in the cone beyond clear_r
    ox, oy, oz, dx, dy, dz = ray
    p = (ox + s0 * dx, oy + s0 * dy, oz + s0 * dz)
    d = (dx, dy, dz)
    i, j, k = _cell(p[0], origin, bucket, dims, 0), _cell(p[1], origin, bucket, dims, 1), _cell(p[2], origin, bucket,
                                                                                                dims, 2)
    step, lo, hi = work[0], work[1], work[2]
    tmax, tdelta = dwork[0], dwork[1]
    _dda_start(p, d, (i, j, k), origin, bucket, step, tmax, tdelta)
    length = s1 - s0
    # Each step's box lies within the 27 buckets round the DDA's own when the walk starts inside the grid (its
    # bucket then is the segment's) and the radius stays below half a bucket: a step whose 27 buckets never held a
    # point (``near == 0``) has nothing to scan.
    fast = max(clear_r + slope * s0, clear_r + slope * s1) + 1e-9 <= 0.5 * bucket
    for a in range(3):
        fast = fast and 0 <= math.floor((p[a] - origin[a]) / bucket) < dims[a]
    t_in = 0.0
    while True:
        c = 0
        if tmax[1] < tmax[c]:
            c = 1
        if tmax[2] < tmax[c]:
            c = 2
        if not fast or near[i, j, k]:
            t_out = min(tmax[c], length)
            grow = clear_r + slope * (s0 + t_out) + 1e-9  # and a nanometre for a point a running mean rounded
            # onto its voxel's face
            for a in range(3):
                x0, x1 = p[a] + t_in * d[a], p[a] + t_out * d[a]
                lo[a] = _cell(min(x0, x1) - grow, origin, bucket, dims, a)
                hi[a] = _cell(max(x0, x1) + grow, origin, bucket, dims, a)
            for a in range(lo[0], hi[0] + 1):
                for b in range(lo[1], hi[1] + 1):
                    for cc in range(lo[2], hi[2] + 1):
                        if head[a, b, cc] < 0 or visit[a, b, cc] == tag:
                            continue  # an empty bucket has nothing to pass; a scanned one is done
                        visit[a, b, cc] = tag
                        if grazing:
                            r, n = _pass_bucket(a, b, cc, ray, s0, s1, clear_r, slope, P, alive, evidence, latent,
                                                mark, tag, head, nxt, forget, established, seen, reading, shadow,
                                                dims, sheet, cand, n_cand)
                        else:
                            r, n = _pass_bucket(a, b, cc, ray, s0, s1, clear_r, slope, P, alive, evidence, latent,
                                                mark, tag, head, nxt, forget, established, seen, reading, shadow,
                                                dims, None, cand, n_cand)
                        removed += r
                        contradicted += n
        if tmax[c] > length:
            break
        t_in = tmax[c]
        tmax[c] += tdelta[c]
        if c == 0:
            i += step[0]
            if i < 0 or i >= dims[0]:
                break
        elif c == 1:
            j += step[1]
            if j < 0 or j >= dims[1]:
                break
        else:
            k += step[2]
            if k < 0 or k >= dims[2]:
                break
    return removed, contradicted


@numba.njit(cache=True)
def _free_along(ox, oy, oz, dx, dy, dz, s, e, free, forigin, fcell, fdims):  # pragma: no cover - jitted
    """Mark the cells along the ray from ``s`` to ``e`` seen free (samples half a cell apart)."""
    step = 0.5 * fcell
    while s < e:
        i = int(math.floor((ox + s * dx - forigin[0]) / fcell))
        j = int(math.floor((oy + s * dy - forigin[1]) / fcell))
        k = int(math.floor((oz + s * dz - forigin[2]) / fcell))
        if 0 <= i < fdims[0] and 0 <= j < fdims[1] and 0 <= k < fdims[2]:
            free[i, j, k] = 1
        s += step


@numba.njit(cache=True)
def _carve(origins, dirs, starts, ends, free, forigin, fcell, fdims, P, alive, evidence, latent, mark, tag0, head,
           visit, nxt, borigin, bucket, bdims, clear_r, slope, clear_back, forget, established,
           seen, reading, shadow, sheet, cand, n_cand, near):  # pragma: no cover - jitted
    """Mark the cells along each ray [start, end) seen free, and pass each ray's clear part (up to ``end -
    clear_back``) through the points it meets (:func:`_pass_along`: ``forget`` them, or count the
    contradicted ones; none with ``clear_r <= 0``).  Returns ``(removed, contradicted)``."""
    removed = 0
    contradicted = 0
    work = np.empty((3, 3), dtype=np.int64)  # the DDA's step and each box's lo, hi: one allocation for all rays
    dwork = np.empty((2, 3))  # its tmax and tdelta
    for r in range(origins.shape[0]):
        ray = (origins[r, 0], origins[r, 1], origins[r, 2], dirs[r, 0], dirs[r, 1], dirs[r, 2])
        _free_along(*ray, starts[r], ends[r], free, forigin, fcell, fdims)
        # points on the clear part of the ray (before end - clear_back) are not there any more
        e_clear = ends[r] - clear_back
        if clear_r <= 0.0 or e_clear <= starts[r]:
            continue
        n_removed, n_contradicted = _pass_along(ray, starts[r], e_clear, clear_r, slope, P, alive, evidence, latent,
                                                mark, tag0 + r, head, visit, nxt, borigin, bucket, bdims, forget,
                                                established, seen, reading, shadow, sheet, cand, n_cand, work, dwork,
                                                near)
        removed += n_removed
        contradicted += n_contradicted
    return removed, contradicted


@numba.njit(cache=True)
def _judge(cand, n_cand, tag0, dirs, seen, reading, view, view_cos, graze_sin, sheet, P, alive, shadow, head, nxt,
           borigin, bucket, bdims):  # pragma: no cover - jitted
    """The reading's candidate contradictions ``cand[:n_cand[0]]`` (point, ray tag), left by :func:`_carve`: each
    point counts once (``seen``), from a ray (``dirs[tag - tag0]``) whose dot product with ``view[q]``, the mean
    direction the point was sensed from, is at least ``view_cos`` (any ray when it is zero: unknown), and that does
    not run along the plane of its neighbours (:func:`~navstack.planner.grazing.along_a_plane`, at less than
    ``asin(graze_sin)``).  Empties the list and
    returns how many count.  Apart from :func:`_carve`, called only when there are candidates: inside its loop
    the plane test made every update slower (68.6-69.6 against 61.2-64.3 us, the tests' recorded readings)."""
    contradicted = 0
    for c in range(n_cand[0]):
        q, r = cand[c, 0], cand[c, 1] - tag0
        if seen[q] == reading:
            continue
        dx, dy, dz = dirs[r, 0], dirs[r, 1], dirs[r, 2]
        vx, vy, vz = view[q, 0], view[q, 1], view[q, 2]
        if not (vx == 0.0 and vy == 0.0 and vz == 0.0) and dx * vx + dy * vy + dz * vz < view_cos:
            continue  # from across the direction it was sensed from
        if graze_sin > 0.0 and along_a_plane(q, _cell(P[q, 0], borigin, bucket, bdims, 0),
                                             _cell(P[q, 1], borigin, bucket, bdims, 1),
                                             _cell(P[q, 2], borigin, bucket, bdims, 2), dx, dy, dz, graze_sin,
                                             sheet[0], sheet[1], sheet[2], P, alive, shadow, head, nxt, bdims):
            continue  # along a plate's face
        seen[q] = reading
        contradicted += 1
    n_cand[0] = 0
    return contradicted


@numba.njit(cache=True)
def _reading_rays(origins, dirs, starts, ranges, hit, informative, hit_backoff, depths):  # pragma: no cover
    """One reading's rays as :meth:`SensedMap.update` takes them apart: the informative rays with a finite
    range (``origins, dirs, starts, ends`` of each, ``end`` being ``hit_backoff`` [m] short of a hit), and the
    points to merge, the hits in ray order and then their shadows, depth by depth (``depths`` [m] behind
    each hit), and the hits' directions; returns ``(o, d, st, ends, points, hit_directions)``.  The same
    operations as numpy's on the masked arrays, in the same order."""
    n = ranges.shape[0]
    use = np.empty(n, dtype=np.bool_)
    n_use = 0
    n_hit = 0
    for r in range(n):
        use[r] = informative[r] and math.isfinite(ranges[r])
        n_use += use[r]
        n_hit += use[r] and hit[r]
    o = np.empty((n_use, 3))
    d = np.empty((n_use, 3))
    st = np.empty(n_use)
    ends = np.empty(n_use)
    pts = np.empty((n_hit * (1 + depths.shape[0]), 3))
    hd = np.empty((n_hit, 3))
    u = 0
    m = 0
    for r in range(n):
        if not use[r]:
            continue
        for c in range(3):
            o[u, c] = origins[r, c]
            d[u, c] = dirs[r, c]
        st[u] = starts[r]
        ends[u] = ranges[r] - hit_backoff if hit[r] else ranges[r]
        u += 1
        if hit[r]:
            rm = ranges[r]
            for c in range(3):
                pts[m, c] = origins[r, c] + rm * dirs[r, c]
                hd[m, c] = dirs[r, c]
            for t in range(depths.shape[0]):
                q = m + (t + 1) * n_hit
                for c in range(3):
                    pts[q, c] = origins[r, c] + (rm + depths[t]) * dirs[r, c]
            m += 1
    return o, d, st, ends, pts, hd


@numba.njit(cache=True)
def _purge_shadows(alive, shadow, n, P, free, forigin, fcell, fdims):  # pragma: no cover - jitted
    """Drop the shadow points whose cell has been seen free; returns how many."""
    removed = 0
    for q in range(n):
        if alive[q] and shadow[q]:
            i = int(math.floor((P[q, 0] - forigin[0]) / fcell))
            j = int(math.floor((P[q, 1] - forigin[1]) / fcell))
            k = int(math.floor((P[q, 2] - forigin[2]) / fcell))
            if 0 <= i < fdims[0] and 0 <= j < fdims[1] and 0 <= k < fdims[2] and free[i, j, k] != 0:
                alive[q] = False
                removed += 1
    return removed


@numba.njit(cache=True)
def _mark_ball(free, forigin, fcell, fdims, cx, cy, cz, radius):  # pragma: no cover - jitted
    """Mark the cells whose centres lie within ``radius`` of (cx, cy, cz) seen free."""
    n = int(math.ceil(radius / fcell)) + 1
    ci = int(math.floor((cx - forigin[0]) / fcell))
    cj = int(math.floor((cy - forigin[1]) / fcell))
    ck = int(math.floor((cz - forigin[2]) / fcell))
    for i in range(max(ci - n, 0), min(ci + n + 1, fdims[0])):
        for j in range(max(cj - n, 0), min(cj + n + 1, fdims[1])):
            for k in range(max(ck - n, 0), min(ck + n + 1, fdims[2])):
                x = forigin[0] + (i + 0.5) * fcell - cx
                y = forigin[1] + (j + 0.5) * fcell - cy
                z = forigin[2] + (k + 0.5) * fcell - cz
                if x * x + y * y + z * z <= radius * radius:
                    free[i, j, k] = 1


# voxel keys: the voxel index (ix, iy, iz) relative to the map origin, packed into one int64
_KEY_BITS = 21
_KEY_OFFSET = 1 << (_KEY_BITS - 1)  # each index must lie in [-_KEY_OFFSET, _KEY_OFFSET)


@numba.njit(cache=True)
def _new_voxel_table():  # pragma: no cover - jitted
    """An empty voxel table: packed voxel key -> point slot (a numba typed dict)."""
    return numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int64)


@numba.njit(cache=True)
def _voxel_keys(pts, origin, voxel):  # pragma: no cover - jitted
    """The packed voxel key of each point (K,), and the index of the first point that is not finite or whose
    voxel index does not fit in the key (-1: none).

    ``floor((p - origin) / voxel)`` per axis, the same IEEE operations as numpy's (no fastmath): the same
    voxel for every point, as the buckets and seen-free cells in :func:`_merge_points`."""
    keys = np.empty(pts.shape[0], dtype=np.int64)
    for t in range(pts.shape[0]):
        key = 0
        for c in range(3):
            f = math.floor((pts[t, c] - origin[c]) / voxel)
            if not -_KEY_OFFSET <= f < _KEY_OFFSET:  # NaN too
                return keys, t
            key = (key << _KEY_BITS) | (int(f) + _KEY_OFFSET)
        keys[t] = key
    return keys, -1


@numba.njit(cache=True)
def _merge_points(first, pts, keys, n_plain, plain_voxels, shadow_voxels, P, count, evidence, latent, alive, nxt,
                  is_shadow, head, n, origin, bucket, bdims, free, free_cell, fdims, average, initial_evidence,
                  max_evidence, changed, n_changed, dirs, view, near):  # pragma: no cover - jitted
    """Merge ``pts[first:]`` (packed voxel ``keys``) into their voxels (:meth:`SensedMap.add_points`), in order,
    writing the points added or moved to ``changed[n_changed:]``: ``pts[:n_plain]`` are surface points (voxels
    ``plain_voxels``), the rest shadow points (``shadow_voxels``); a bucket's first point sets ``near`` on the
    27 buckets round it.

    Stops before the first point that needs a new slot when all ``P.shape[0]`` are in use.  Returns
    ``(points done, slots in use, n_changed)``."""
    for t in range(first, pts.shape[0]):
        px, py, pz = pts[t, 0], pts[t, 1], pts[t, 2]
        key = keys[t]
        shadow = t >= n_plain
        voxels = shadow_voxels if shadow else plain_voxels
        idx = voxels[key] if key in voxels else -1
        if shadow:
            if idx >= 0:
                continue  # a shadow is placed once ...
            i = int(math.floor((px - origin[0]) / free_cell))
            j = int(math.floor((py - origin[1]) / free_cell))
            k = int(math.floor((pz - origin[2]) / free_cell))
            if 0 <= i < fdims[0] and 0 <= j < fdims[1] and 0 <= k < fdims[2] and free[i, j, k] != 0:
                continue  # ... and never where a ray has been
        if idx >= 0 and alive[idx]:
            c = min(count[idx] + 1, average)
            count[idx] = c
            evidence[idx] = min(evidence[idx] + 1, max_evidence)
            latent[idx] = min(latent[idx] + 1, max_evidence) if latent[idx] > 0 else initial_evidence  # put back
            sx = (px - P[idx, 0]) / c
            sy = (py - P[idx, 1]) / c
            sz = (pz - P[idx, 2]) / c
            if t < dirs.shape[0]:  # the direction it was sensed from: the same running mean
                unknown = view[idx, 0] == 0.0 and view[idx, 1] == 0.0 and view[idx, 2] == 0.0
                for a in range(3):  # (from this hit on, for a point added without a direction)
                    view[idx, a] = dirs[t, a] if unknown else view[idx, a] + (dirs[t, a] - view[idx, a]) / c
            P[idx, 0] += sx
            P[idx, 1] += sy
            P[idx, 2] += sz
            if sx * sx + sy * sy + sz * sz > 1e-6:
                changed[n_changed, 0] = P[idx, 0]
                changed[n_changed, 1] = P[idx, 1]
                changed[n_changed, 2] = P[idx, 2]
                n_changed += 1
            continue
        if idx < 0:
            if n == P.shape[0]:
                return t, n, n_changed
            idx = n
            n += 1
            voxels[key] = idx
            bi = _cell(px, origin, bucket, bdims, 0)
            bj = _cell(py, origin, bucket, bdims, 1)
            bk = _cell(pz, origin, bucket, bdims, 2)
            if head[bi, bj, bk] < 0:  # the bucket's first point: the 27 round it have one near (``near``)
                for a in range(max(bi - 1, 0), min(bi + 2, bdims[0])):
                    for b in range(max(bj - 1, 0), min(bj + 2, bdims[1])):
                        for cc in range(max(bk - 1, 0), min(bk + 2, bdims[2])):
                            near[a, b, cc] = 1
            nxt[idx] = head[bi, bj, bk]
            head[bi, bj, bk] = idx
            is_shadow[idx] = shadow
        P[idx, 0] = px
        P[idx, 1] = py
        P[idx, 2] = pz
        count[idx] = 1
        evidence[idx] = initial_evidence
        latent[idx] = initial_evidence
        alive[idx] = True
        for a in range(3):
            view[idx, a] = dirs[t, a] if t < dirs.shape[0] else 0.0
        changed[n_changed, 0] = px
        changed[n_changed, 1] = py
        changed[n_changed, 2] = pz
        n_changed += 1
    return pts.shape[0], n, n_changed


def _rows3(a: ArrayLike) -> NDArray[np.float64]:
    """``a`` as a C-contiguous float (R, 3) array (a ``ValueError`` naming its shape otherwise)."""
    out = np.ascontiguousarray(a, dtype=np.float64)
    if out.ndim != 2 or out.shape[1] != 3:
        raise ValueError(f"SensedMap.update: origins and directions must be (R, 3) arrays, got shape {out.shape}")
    return out


_NO_DIRECTIONS = np.empty((0, 3))


MAX_FREE_CELLS = 40_000_000
"""The most seen-free cells a :class:`SensedMap` holds (a byte each, and the navigation function's grid)."""
FINE_CELLS = 8_000_000
"""The most cells of a finer grid than ``MapConfig.free_cell_fallback``: the 1 cm grid of a typical world (0.6-0.8 M
cells at 2 cm, 4.5-6.5 M at 1 cm: ``worlds/hard12/thin_slot.json``, the paper truss).  The navigation function's and
the map's memory grow with the cells, so a wide world keeps coarser ones."""


class MapTooLarge(ValueError):
    """The start and goals span more than a :class:`SensedMap` of the configured cells can hold."""


def _fitting_cells(cfg: MapConfig, extent: NDArray[np.float64]) -> MapConfig:
    """``cfg`` itself, or with the coarser seen-free cells ``free_cell_fallback`` allows when its finer
    ``free_cell`` would need more than :data:`FINE_CELLS` over ``extent`` [m]."""
    def cells(side: float) -> int:
        return int(np.prod(np.ceil(extent / side).astype(np.int64) + 1))

    base = cfg.free_cell_fallback
    if base is None or cfg.free_cell >= base or cells(cfg.free_cell) <= FINE_CELLS:
        return cfg
    for j in range(int(round(base / cfg.free_cell)) - 1, 1, -1):
        if cells(base / j) <= FINE_CELLS:
            return replace(cfg, free_cell=base / j)
    return replace(cfg, free_cell=base)


# ------------------------------------------------------------------------------------------ class
class SensedMap:
    """Surface points and seen-free cells over the box ``lo .. hi`` [m] (see the module docstring)."""

    def __init__(self, lo: ArrayLike, hi: ArrayLike, config: MapConfig | None = None) -> None:
        cfg = config or MapConfig()
        lo = np.asarray(lo, dtype=np.float64) - cfg.margin
        hi = np.asarray(hi, dtype=np.float64) + cfg.margin
        if lo.shape != (3,) or hi.shape != (3,) or not (np.isfinite(lo).all() and np.isfinite(hi).all()):
            raise ValueError("SensedMap: lo and hi must be finite 3-vectors [m]")
        if np.any(hi <= lo):
            raise ValueError(f"SensedMap: empty box {lo} .. {hi}")
        # buckets on the voxel lattice: origin a multiple of the voxel
        self.origin = np.floor(lo / cfg.voxel) * cfg.voxel
        self.bucket_dims = np.ceil((hi - self.origin) / cfg.bucket).astype(np.int64) + 1
        cfg = _fitting_cells(cfg, hi - self.origin)
        self.config = cfg
        self.free_dims = np.ceil((hi - self.origin) / cfg.free_cell).astype(np.int64) + 1
        cells = int(np.prod(self.free_dims))
        if cells > MAX_FREE_CELLS or int(np.prod(self.bucket_dims)) > 4_000_000:
            raise MapTooLarge(f"SensedMap: the box {lo} .. {hi} [m] (start and goals grown by MapConfig.margin = "
                              f"{cfg.margin:g} m) is too large for a local map: {cells:,} seen-free cells of "
                              f"MapConfig.free_cell = {cfg.free_cell:g} m, more than {MAX_FREE_CELLS:,}")
        self.head = np.full(tuple(self.bucket_dims), -1, dtype=np.int64)
        self._visit = np.full(tuple(self.bucket_dims), -1, dtype=np.int64)  # the last ray that scanned a bucket
        self._near = np.zeros(tuple(self.bucket_dims), dtype=np.uint8)  # 1: one of the 27 buckets round it held a point
        self.free = np.zeros(tuple(self.free_dims), dtype=np.uint8)
        self._P = np.zeros((1024, 3))
        self._count = np.zeros(1024, dtype=np.int64)
        self._evidence = np.zeros(1024, dtype=np.int64)
        self._latent = np.zeros(1024, dtype=np.int64)  # the evidence forgetting would have left (until it begins)
        self._mark = np.full(1024, -1, dtype=np.int64)
        self._seen = np.full(1024, -1, dtype=np.int64)  # the last reading that counted the point contradicted
        self._rays = 0  # rays cast into the map so far: each ray's tag in the clearing kernels
        self._alive = np.zeros(1024, dtype=np.bool_)
        self._next = np.full(1024, -1, dtype=np.int64)
        self._shadow = np.zeros(1024, dtype=np.bool_)
        self._view = np.zeros((1024, 3))  # the mean direction a point was sensed from (0: added without one)
        self._view_cos = math.cos(cfg.motion_view_angle)
        self._graze_sin = math.sin(cfg.motion_graze_angle)
        self._cand = np.zeros((4096, 2), dtype=np.int64)  # a reading's candidate contradictions: (point, ray tag)
        self._n_cand = np.zeros(1, dtype=np.int64)
        self._n = 0
        # packed voxel key -> slot (numba typed dicts), for the sensed points and the shadows
        self._voxels = _new_voxel_table()
        self._shadow_voxels = _new_voxel_table()
        self.version = 0
        """Incremented whenever a point is added, moved by more than a millimetre, or removed."""
        self.revision = 0
        """Incremented by every call that may change a point at all (:meth:`update`, :meth:`add_points`): what a
        snapshot of the points (:func:`navstack.planner.proximity.point_index`) is valid for."""
        self.forgotten = 0
        """Points forgotten so far (clean passes took their evidence, or forgetting began without it left)."""
        self.snapshot: tuple | None = None
        """``(revision, snapshot)``: the last snapshot of the points made by a proximity index, for reuse."""
        self.new_points = np.empty((0, 3))
        """Points added or moved by the last :meth:`update` (K, 3) [m]."""
        self._depths = np.array(cfg.shadow_depths, dtype=np.float64).reshape(-1)
        self._sheet = (float(cfg.sheet_radius), int(cfg.sheet_min_points), float(cfg.sheet_line_ratio))
        self.forgetting = cfg.forget_moved
        """Rays' clean passes lower the points' evidence: from the start with ``forget_moved``, else from the
        reading after motion was sensed."""
        self.readings = 0
        """Readings fused by :meth:`update` so far."""
        self.contradicted = 0
        """Established points the last reading contradicted (module docstring, "Sensing motion"; 0 once forgetting:
        not counted)."""
        self._recent = np.zeros(cfg.motion_window, dtype=np.int64)  # contradictions of the last readings
        self.motion_sensed_at: int | None = None
        """The reading (1 = the first) whose contradictions turned forgetting on (None: not yet, or never)."""
        self.forgetting_for_a_while = False
        """Forgetting because :meth:`begin_forgetting` said so, until :meth:`end_forgetting`."""

    # ---- storage
    @property
    def n_points(self) -> int:
        """Number of live surface points."""
        return int(self._alive[: self._n].sum())

    @property
    def n_slots(self) -> int:
        """Number of point slots in use (live and removed points)."""
        return self._n

    @property
    def points(self) -> NDArray[np.float64]:
        """The live surface points (N, 3) [m] (a copy), shadows included."""
        return self._P[: self._n][self._alive[: self._n]].copy()

    @property
    def surface_points(self) -> NDArray[np.float64]:
        """The live points that were sensed (M, 3) [m] (a copy): no shadows."""
        keep = self._alive[: self._n] & ~self._shadow[: self._n]
        return self._P[: self._n][keep].copy()

    def arrays(self) -> tuple:
        """The arrays the numba kernels take: ``(P, alive, head, next, origin, bucket, bucket_dims)``."""
        return (self._P, self._alive, self.head, self._next, self.origin, self.config.bucket, self.bucket_dims)

    def free_arrays(self) -> tuple:
        """``(free, origin, free_cell, free_dims)``."""
        return (self.free, self.origin, self.config.free_cell, self.free_dims)

    def _grow(self) -> None:
        cap = 2 * self._P.shape[0]
        for name, fill in (("_P", 0.0), ("_count", 0), ("_evidence", 0), ("_latent", 0), ("_mark", -1), ("_seen", -1),
                           ("_alive", False), ("_next", -1), ("_shadow", False), ("_view", 0.0)):
            old = getattr(self, name)
            new = np.full((cap,) + old.shape[1:], fill, dtype=old.dtype)
            new[: self._n] = old[: self._n]
            setattr(self, name, new)

    def add_points(self, pts: ArrayLike, shadow: bool = False) -> None:
        """Merge surface points (K, 3) [m] into their voxels (``shadow``: shadow points, kept apart, never
        put in a cell already seen free).

        A voxel's first point takes a new slot, linked into the bucket holding it; each further point moves
        it a step of the running mean over at most ``average`` samples and adds one evidence (up to
        ``max_evidence``); a point in a voxel whose point was removed puts it back (``initial_evidence``).  A
        shadow is placed once: a shadow voxel takes no further points, even once its point is removed."""
        pts = np.ascontiguousarray(np.asarray(pts, dtype=np.float64).reshape(-1, 3))
        self._merge(pts, 0 if shadow else pts.shape[0])

    def _merge(self, pts: NDArray[np.float64], n_plain: int, dirs: NDArray[np.float64] = _NO_DIRECTIONS) -> None:
        """Merge ``pts`` (K, 3), contiguous, in order: the first ``n_plain`` as surface points, the rest as
        shadow points (one compiled pass; :meth:`add_points` on each part in turn does the same)."""
        cfg = self.config
        self.revision += 1
        keys, bad = _voxel_keys(pts, self.origin, cfg.voxel)
        if bad >= 0:
            raise ValueError(f"SensedMap.add_points: point {pts[bad]} is not finite or lies more than {_KEY_OFFSET} "
                             f"voxels ({_KEY_OFFSET * cfg.voxel:g} m) from the map origin {self.origin}")
        changed = np.empty((pts.shape[0], 3))
        done = n_changed = 0
        while True:
            done, self._n, n_changed = _merge_points(
                done, pts, keys, n_plain, self._voxels, self._shadow_voxels, self._P, self._count, self._evidence,
                self._latent, self._alive, self._next, self._shadow, self.head, self._n, self.origin, cfg.bucket,
                self.bucket_dims, self.free, cfg.free_cell, self.free_dims, cfg.average, cfg.initial_evidence,
                cfg.max_evidence, changed, n_changed, dirs, self._view, self._near)
            if done == pts.shape[0]:
                break
            self._grow()  # out of slots: double them, and go on from the point that needed one
        if n_changed:
            self.version += 1
            self.new_points = np.vstack([self.new_points, changed[:n_changed]])

    def update(self, origins: ArrayLike, directions: ArrayLike, starts: ArrayLike, ranges: ArrayLike,
               hit: ArrayLike, informative: ArrayLike) -> None:
        """Fuse one reading: rays (R,) from ``origins`` along unit ``directions``, seen from ``starts`` [m].

        ``hit``: the ray ends on a surface at ``ranges``; a ray that is ``informative`` but not ``hit``
        saw free space up to ``ranges`` (its maximum range).  Rays that are not informative (dropouts,
        coasting tracks) are ignored.
        """
        self.new_points = np.empty((0, 3))
        cfg = self.config
        rays = (_rows3(origins), _rows3(directions), np.ascontiguousarray(starts, dtype=np.float64),
                np.ascontiguousarray(ranges, dtype=np.float64), np.ascontiguousarray(hit, dtype=np.bool_),
                np.ascontiguousarray(informative, dtype=np.bool_))
        if any(a.shape[0] != rays[3].shape[0] for a in rays) or any(a.ndim != 1 for a in rays[2:]):
            raise ValueError("SensedMap.update: origins, directions (R, 3) and starts, ranges, hit, informative (R,) "
                             f"must agree, got shapes {[a.shape for a in rays]}")
        o, d, st, ends, pts, hit_dirs = _reading_rays(*rays, cfg.hit_backoff, self._depths)
        n_hit = hit_dirs.shape[0]
        self.readings += 1
        passing = self.forgetting or cfg.detect_motion
        radius, slope = self._clean_pass()
        removed, self.contradicted = _carve(
            o, d, st, ends, self.free, self.origin, cfg.free_cell, self.free_dims, self._P, self._alive, self._evidence,
            self._latent, self._mark, self._rays, self.head, self._visit, self._next, self.origin, cfg.bucket,
            self.bucket_dims, radius if passing else 0.0, slope, cfg.clear_backoff, self.forgetting, cfg.max_evidence,
            self._seen, self.readings, self._shadow, self._sheet, self._cand, self._n_cand, self._near)
        if self._n_cand[0]:
            self.contradicted += _judge(self._cand, self._n_cand, self._rays, d, self._seen, self.readings, self._view,
                                        self._view_cos, self._graze_sin, self._sheet, self._P, self._alive,
                                        self._shadow, self.head, self._next, self.origin, cfg.bucket, self.bucket_dims)
        self._rays += o.shape[0]
        self._recent[self.readings % cfg.motion_window] = self.contradicted
        if not self.forgetting and self._recent.sum() >= cfg.motion_contradictions:
            removed += self._begin_forgetting()
        self._forgot(removed)
        if n_hit:  # the hits, then their shadows depth by depth, in one pass
            self._merge(pts, n_hit, hit_dirs)
        if _purge_shadows(self._alive, self._shadow, self._n, self._P, self.free, self.origin, cfg.free_cell,
                          self.free_dims):
            self.version += 1
            self.revision += 1

    def _clean_pass(self) -> tuple[float, float]:
        """The clean-pass radius [m] at a ray's origin and its growth along the ray [m/m]: ``sensed_clear_radius``
        and ``sensed_clear_slope`` once motion has been sensed, else ``clear_radius`` and 0."""
        cfg = self.config
        if self.motion_sensed_at is not None:
            return cfg.sensed_clear_radius, cfg.sensed_clear_slope
        return cfg.clear_radius, 0.0

    def _forgot(self, removed: int) -> None:
        """Count ``removed`` forgotten points (and a new version of the map if any)."""
        if removed:
            self.forgotten += removed
            self.version += 1
            self.revision += 1

    def begin_forgetting(self) -> int:
        """Forget from now on, as if motion had been sensed (a planner boxed in by what it has seen, waiting: what
        moved may have been seen only in passing, never often enough to be established and contradicted), until
        :meth:`end_forgetting`; no change once forgetting.  Returns how many points went at once."""
        if self.forgetting:
            return 0
        removed = self._begin_forgetting()
        self.forgetting_for_a_while = True
        self._forgot(removed)
        return removed

    def end_forgetting(self) -> None:
        """End the forgetting :meth:`begin_forgetting` began (the planner's wait is over): clean passes count
        against no point again, and the map senses motion afresh (each point's latent evidence starts from its
        evidence); what went stays gone.  No change when the map forgets because it sensed motion itself, or
        from the start (``forget_moved``)."""
        if not self.forgetting_for_a_while:
            return
        self.forgetting_for_a_while = False
        self.forgetting = False
        self.motion_sensed_at = None
        n = self._n
        self._latent[:n] = self._evidence[:n]
        self._recent[:] = 0

    def _begin_forgetting(self) -> int:
        """Motion is sensed: forget from now on, starting from the evidence forgetting would have left
        (``_latent``: the clean passes so far count, as if the map had forgotten from the start); the points
        it would have removed go now.  Returns how many."""
        self.forgetting = True
        self.motion_sensed_at = self.readings
        n = self._n
        gone = self._alive[:n] & (self._latent[:n] <= 0)
        self._alive[:n] &= ~gone
        self._evidence[:n] = np.maximum(self._latent[:n], 0)
        return int(gone.sum())

    def mark_free(self, centre: ArrayLike, radius: float) -> None:
        """The robot has been here: the cells within ``radius`` [m] of ``centre`` are seen free."""
        c = np.asarray(centre, dtype=np.float64)
        _mark_ball(self.free, self.origin, self.config.free_cell, self.free_dims, c[0], c[1], c[2], radius)

    def distance(self, p: ArrayLike, r: float | None = None) -> float:
        """Distance [m] from ``p`` to the nearest surface point (exact below ``r``, default ``bucket``, else ``r``)."""
        q = np.asarray(p, dtype=np.float64)
        rr = self.config.bucket if r is None else float(r)
        return float(nearest_distance(q[0], q[1], q[2], rr, *self.arrays()))

    def is_seen_free(self, p: ArrayLike) -> bool:
        """True if the cell holding ``p`` has been seen free (False outside the map)."""
        idx = np.floor((np.asarray(p, dtype=np.float64) - self.origin) / self.config.free_cell).astype(np.int64)
        if np.any(idx < 0) or np.any(idx >= self.free_dims):
            return False
        return bool(self.free[tuple(idx)])

    def inside(self, p: ArrayLike) -> bool:
        """True if ``p`` lies in the mapped box."""
        q = np.asarray(p, dtype=np.float64)
        top = self.origin + self.free_dims * self.config.free_cell
        return bool(np.all(q >= self.origin) and np.all(q < top))
