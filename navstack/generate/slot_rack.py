"""``slot-rack``: slotted walls and pipe racks in any orientation; the goals do not mark the slots.

2-3 rows, each either parallel pipes (radius 0.02-0.05 m, the gaps between neighbours all one slot
width) or a slotted plate (0.012-0.03 m thick, a window of the slot width and 0.3-0.6 m long, sometimes
a second window on the other side of the line).  The rows stand across the approach line (the tip's
heading) from the entry goal to the final goal, 0.33-0.65 m apart; the whole rack is rolled about that
line by a random angle (pipes and slots horizontal, vertical or oblique).  The slot each row offers near
the line is 0.12-0.15 m wide (surface to surface) and its centre alternates from one side of the line to
the other (random first side), at least w/2 - 0.02 m off the line, so the straight line comes within
the tip's radius (0.025 m) of every row: going straight collides.  One or two spheres (radius
0.03-0.07 m) stand between the rows beside the reference path.

Goals: only an entry goal 0.22-0.32 m ahead of the tip, 0.15-0.2 m before the first row's axis plane,
and the final goal on the line 0.18-0.25 m behind the last row.

Reference path (built, not searched): a lateral profile y(x) along the line, in the plane of the slot
offsets; straight at the slot's offset p_k while crossing row k (so the links in the slot are straight),
and S-curves of two parabolas between the rows, designed for a radius of :data:`DESIGN_RADIUS`
(0.3 m; the spline through its samples must keep 0.25 m).  The entry S-curve starts before the entry
goal and passes it e mm off its centre (e <= 16 mm; the least that lets it turn with 0.3 m, or more),
already turning: the goal's tolerance (0.02 m, checked
at 90 %) is used as the notes on finding the way say a solvable path must use it; p_0 is limited by
what that early start allows.  The via points are samples of y(x) every 4 cm.

Difficulty d (0..1): a third row with probability 0.15 + 0.6 d; row spacing drawn in
[max(0.33, 0.5 - 0.2 d), 0.65 - 0.2 d] m (at most 0.35 m with three rows, for the length rule); slot
width 0.15 - 0.03 d m (minus up to 5 mm, at least 0.12 m: the tip capsule of radius 0.025 m plus the
0.015 m path margin on both sides leaves a band of at least 0.04 m); a second sphere with probability
0.2 + 0.6 d; sphere surface 0.02 + (0.05 (1 - d) + 0.01) x U(0, 1) m from the tip's path.

A robot of another serpentine radius r (``sized-slot-rack``, :mod:`~navstack.generate.sized`) gets slots
2 (r - 0.025) m wider, so the same room on each side of its body, and slot centres as near the line as
keep the straight line blocked for its radius.  For the default robot every number is the same as before
(the shift is exactly 0.0).
Units: metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from navstack.generate.base import HEADING, SERPENTINE_RADIUS, TIP, Candidate, make_guard, place
from navstack.generate.checks import CheckConfig, RobotStart, path_samples
from navstack.generate.geometry import FloatArray, cylinder_dict, obstacle_distance
from navstack.generate.sparse import (
    BLOCKED_DEPTH,
    SPARSE_CHECKS,
    arc_at,
    ball_between,
    box_on_axes,
    cross_axes,
    obstacles_of,
    sparse_config,
)

__all__ = ["DESIGN_RADIUS", "ROW_EXTENT", "Layout", "Way", "entry_range", "entry_start", "family_slot_rack",
           "path_offsets", "pipe_row", "plate_row", "profile", "row_offsets", "s_curve", "way_through"]

ROW_EXTENT = 0.4
"""Half width [m] of every row across the line (pipes whose axis is within it; plates out to it)."""

DESIGN_RADIUS = 0.3
"""Turn radius [m] the reference profile is designed for (the checks demand 0.25 m of the spline)."""

ENTRY_MAX = 0.016
"""Largest distance [m] of the reference path from the entry goal's centre (tolerance 0.02 m x 0.9 - 2 mm)."""

VIA_STEP = 0.04
"""Spacing [m] of the via points sampled from the profile."""


# --------------------------------------------------------------------------- rows


def row_offsets(slot: float, width: float, member: float) -> list[float]:
    """Offsets [m] of a row's members (``member`` [m] across, along the row) within :data:`ROW_EXTENT` of its
    centre, so that every gap between two is ``width`` [m] surface to surface and one gap is centred ``slot``
    [m] from the centre."""
    pitch = width + member
    first = slot + width / 2.0 + member / 2.0
    return [first + j * pitch for j in range(-20, 21) if abs(first + j * pitch) <= ROW_EXTENT]


def pipe_row(centre: FloatArray, a: FloatArray, n: FloatArray, slot: float, width: float, radius: float,
             half_length: float) -> list[dict[str, Any]]:
    """Pipes along ``a`` in the plane through ``centre``, spaced along ``n`` so that every gap is
    ``width`` [m] surface to surface and one gap is centred ``slot`` [m] from ``centre`` along ``n``."""
    return [cylinder_dict(centre + o * n - half_length * a, centre + o * n + half_length * a, radius)
            for o in row_offsets(slot, width, 2.0 * radius)]


def plate_row(centre: FloatArray, u: FloatArray, a: FloatArray, n: FloatArray, windows: list[tuple[float, ...]],
              thickness: float, half_length: float) -> list[dict[str, Any]]:
    """A plate across ``u`` (``thickness`` [m]) spanning ``a`` in [-half_length, half_length] and ``n`` in
    [-ROW_EXTENT, ROW_EXTENT] around ``centre``, with rectangular ``windows`` (n centre, width, a low,
    a high) [m], as boxes: full-length strips between the windows and the blocks beyond each window's ends."""
    axes = np.column_stack([u, a, n])
    out = []

    def block(n0: float, n1: float, a0: float, a1: float) -> None:
        if n1 - n0 > 1e-4 and a1 - a0 > 1e-4:
            c = centre + 0.5 * (n0 + n1) * n + 0.5 * (a0 + a1) * a
            out.append(box_on_axes(c, axes, (thickness / 2.0, (a1 - a0) / 2.0, (n1 - n0) / 2.0)))

    edge = -ROW_EXTENT
    for nc, w, a0, a1 in sorted(windows):
        block(edge, nc - w / 2.0, -half_length, half_length)
        block(nc - w / 2.0, nc + w / 2.0, -half_length, a0)
        block(nc - w / 2.0, nc + w / 2.0, a1, half_length)
        edge = nc + w / 2.0
    block(edge, ROW_EXTENT, -half_length, half_length)
    return out


# --------------------------------------------------------------------------- the reference profile


def s_curve(t: FloatArray) -> FloatArray:
    """0 -> 1 on t in [0, 1] as two parabolas (constant |second derivative| 4), flat at both ends."""
    return np.where(t <= 0.5, 2.0 * t * t, 1.0 - 2.0 * (1.0 - t) ** 2)


def entry_start(delta: float, reach: float, e: float) -> tuple[float, float]:
    """Where (x [m], relative to the entry goal) an S-curve of height ``delta`` [m] ending at ``reach``
    must start to be ``e`` [m] high at the entry goal (x = 0), and its radius [m] (D^2 / (4 delta))."""
    f = e / delta
    t = np.sqrt(f / 2.0) if f <= 0.5 else 1.0 - np.sqrt((1.0 - f) / 2.0)
    length = reach / (1.0 - t)
    return reach - length, length**2 / (4.0 * delta)


def entry_range(delta: float, reach: float, standoff: float) -> tuple[float, float] | None:
    """Entry offsets e [m] the entry S-curve of height ``delta`` may pass the entry goal with: at most
    :data:`ENTRY_MAX`, starting at least 0.06 m ahead of the tip, turning with :data:`DESIGN_RADIUS` at
    least; None when there are none."""
    longest = reach + standoff - 0.06
    t = 1.0 - reach / longest
    e_hi = min(ENTRY_MAX, 0.999 * delta, float(delta * s_curve(np.array(t))))
    if e_hi <= 0.0 or entry_start(delta, reach, e_hi)[1] < DESIGN_RADIUS:
        return None
    lo, hi = 0.0, e_hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if entry_start(delta, reach, mid)[1] >= DESIGN_RADIUS else (mid, hi)
    return hi, e_hi


@dataclass
class Layout:
    """The drawn rack in line coordinates: x along the line from the entry goal, y the slot offsets [m]."""

    kind: str
    xs: FloatArray  # row axis planes
    halves: FloatArray  # half length of the straight stretch around each row
    widths: FloatArray
    depths: FloatArray  # pipe radius or half plate thickness
    standoff: float  # tip -> entry goal
    final: float  # x of the final goal
    roll: float


def _draw_layout(rng: np.random.Generator, difficulty: float, grow: float = 0.0) -> Layout:
    """The rows; slots ``2 grow`` [m] wider than for the default body (``grow``: the body's radius less 0.025 m)."""
    n_rows = 3 if rng.random() < 0.15 + 0.6 * difficulty else 2
    gaps = rng.uniform(max(0.33, 0.5 - 0.2 * difficulty), 0.65 - 0.2 * difficulty, size=n_rows - 1)
    if n_rows == 3:
        gaps = np.minimum(gaps, 0.35)
    kind = "pipes" if rng.random() < 0.65 else "plates"
    depths = rng.uniform(0.02, 0.05, size=n_rows) if kind == "pipes" else rng.uniform(0.006, 0.015, size=n_rows)
    width = max(0.12, 0.15 - 0.03 * difficulty - rng.uniform(0.0, 0.005)) + 2.0 * grow
    widths = np.clip(width + rng.uniform(-0.003, 0.003, size=n_rows), 0.12 + 2.0 * grow, 0.15 + 2.0 * grow)
    first = rng.uniform(0.15, 0.2)
    xs = first + np.concatenate([[0.0], np.cumsum(gaps)])
    near = np.minimum(np.append(gaps, np.inf), np.insert(gaps, 0, np.inf))  # nearest neighbour row
    halves = np.clip(depths + rng.uniform(0.005, 0.025, size=n_rows), 0.02, np.maximum(0.02, (near - 0.25) / 2))
    return Layout(kind=kind, xs=xs, halves=halves, widths=widths, depths=depths,
                   standoff=float(rng.uniform(0.22, 0.32)), final=float(xs[-1] + rng.uniform(0.18, 0.25)),
                   roll=float(rng.uniform(0.0, np.pi)))


def path_offsets(rng: np.random.Generator, L: Layout, band: FloatArray, grow: float = 0.0) -> FloatArray | None:
    """|p_k| [m]: the path's offset while crossing row k, drawn row by row within what the slot (the line
    blocked, the path inside its band) and the turn radius (entry, between rows, to the final goal) allow.
    ``grow``: the body's radius less 0.025 m."""
    lb = 0.05 * L.widths + 0.017 - 0.1 * grow  # below this no slot both blocks the line and holds the path
    ub = L.widths / 2 + 0.015 + 0.9 * band
    caps = [((L.xs[k + 1] - L.halves[k + 1]) - (L.xs[k] + L.halves[k])) ** 2 / (4 * DESIGN_RADIUS)
            for k in range(len(L.xs) - 1)]
    tail = (L.final - L.xs[-1] - L.halves[-1]) ** 2 / (2 * DESIGN_RADIUS) + 0.012
    reach = L.xs[0] - L.halves[0]
    p: list[float] = []
    for k in range(len(L.xs)):
        hi = ub[k]
        if k == 0:  # the largest entry shift that an early start (within ENTRY_MAX) still allows
            grid = np.linspace(lb[0], ub[0], 40)
            ok = [d for d in grid if entry_range(float(d), reach, L.standoff) is not None]
            hi = max(ok) if ok else -1.0
        else:
            hi = min(hi, caps[k - 1] - p[-1])
        hi = min(hi, caps[k] - lb[k + 1]) if k < len(caps) else min(hi, tail)
        if hi < lb[k]:
            return None
        p.append(float(rng.uniform(lb[k], hi)))
    return np.array(p)


def profile(L: Layout, y: FloatArray, e: float, y_final: float) -> FloatArray:
    """Samples (x, y) [m] of the reference profile: entry S-curve, straight at y_k across each row,
    S-curves between rows, a parabola to ``y_final`` at the final goal."""
    x_start, _ = entry_start(abs(y[0]), L.xs[0] - L.halves[0], e)
    pieces = [(x_start, L.xs[0] - L.halves[0], 0.0, y[0], "s")]
    for k in range(len(L.xs)):
        pieces.append((L.xs[k] - L.halves[k], L.xs[k] + L.halves[k], y[k], y[k], "s"))
        if k + 1 < len(L.xs):
            pieces.append((L.xs[k] + L.halves[k], L.xs[k + 1] - L.halves[k + 1], y[k], y[k + 1], "s"))
    pieces.append((L.xs[-1] + L.halves[-1], L.final, y[-1], y_final, "j"))
    out = []
    for x0, x1, y0, y1, shape in pieces:
        m = max(int(np.ceil((x1 - x0) / VIA_STEP)), 1)
        t = np.arange(m) / m
        f = s_curve(t) if shape == "s" else t * t  # "j": leaves y0 straight, arrives turning
        out.append(np.column_stack([x0 + t * (x1 - x0), y0 + f * (y1 - y0)]))
    out.append(np.array([[L.final, y_final]]))
    return np.concatenate(out)


@dataclass
class Way:
    """The way through a rack's rows: the rows' frame (``a`` along them, ``n`` across, both across the
    heading), the entry goal, each row's slot centre and the path's offset there (signed, along ``n``), the
    entry offset ``e`` [m] and the reference via points (m, 3) [m]."""

    a: FloatArray
    n: FloatArray
    entry: FloatArray
    slots: FloatArray
    offsets: FloatArray
    e: float
    via: FloatArray


def way_through(rng: np.random.Generator, L: Layout, robot: RobotStart, cfg: CheckConfig) -> Way:
    """The way through the rows of ``L`` (rolled ``L.roll`` about the heading): slots on alternating sides
    (the first side random) whose band keeps the tip ``cfg.path_margin`` from their edges, and the profile
    through them.  Rows with no room for the profile give offsets the checks reject (the next attempt
    redraws)."""
    u = HEADING
    a, n = cross_axes(u, L.roll)
    entry = TIP + L.standoff * u
    band = L.widths / 2 - robot.serpentine_radius - cfg.path_margin  # |path - slot centre| allowed
    grow = robot.serpentine_radius - SERPENTINE_RADIUS  # exactly 0.0 for the default body
    side = 1.0 if rng.random() < 0.5 else -1.0
    signs = side * (-1.0) ** np.arange(len(L.xs))
    p = path_offsets(rng, L, band, grow)
    if p is None:  # no room for these rows: a candidate the checks reject (the next attempt redraws)
        p = 0.05 * L.widths + 0.017
    # the slot's near edge at most the body's radius less 5 mm beyond the line: going straight collides
    lo = np.maximum(L.widths / 2 - (0.02 + grow), p - 0.9 * band)
    hi = np.maximum(lo, np.minimum(p + 0.9 * band, L.widths / 2 + 0.015))
    slots = signs * rng.uniform(lo, hi)
    e_lo, e_hi = entry_range(float(p[0]), float(L.xs[0] - L.halves[0]), L.standoff) or (ENTRY_MAX, ENTRY_MAX)
    e = float(rng.uniform(e_lo, e_hi))
    y_final = signs[-1] * rng.uniform(0.0, 0.012)
    prof = profile(L, signs * p, e, y_final)
    via = entry + prof[:, :1] * u + prof[:, 1:] * n
    return Way(a, n, entry, slots, signs * p, e, via[np.linalg.norm(via - TIP, axis=1) > 0.05])


# --------------------------------------------------------------------------- the family


def _rows(rng: np.random.Generator, L: Layout, slots: FloatArray, entry: FloatArray, u: FloatArray,
          a: FloatArray, n: FloatArray) -> tuple[list[dict[str, Any]], list[list[float]]]:
    """Obstacles of every row, and the windows of the plates (n centre, width, a low, a high, row)."""
    half_length = rng.uniform(0.45, 0.6)
    shift = rng.uniform(-0.05, 0.05)  # of the rack along a
    obstacles: list[dict[str, Any]] = []
    windows_all: list[list[float]] = []
    for k, x in enumerate(L.xs):
        centre = entry + x * u + shift * a
        c, w = float(slots[k]), float(L.widths[k])
        if L.kind == "pipes":
            obstacles += pipe_row(centre, a, n, c, w, float(L.depths[k]), half_length)
            continue
        length = rng.uniform(0.3, 0.6)
        a0 = -shift + rng.uniform(-0.05, 0.05) - length / 2
        windows = [(c, w, a0, a0 + length)]
        if rng.random() < 0.5:  # a second window on the other side of the line
            w2 = w + rng.uniform(0.0, 0.02)
            c2 = c - np.sign(c) * (w / 2 + rng.uniform(0.06, 0.12) + w2 / 2)
            if abs(c2) + w2 / 2 <= ROW_EXTENT - 0.05:
                windows.append((c2, w2, a0, a0 + length))
        windows_all += [[round(float(v), 4) for v in win] + [k] for win in windows]
        obstacles += plate_row(centre, u, a, n, windows, 2.0 * float(L.depths[k]), half_length)
    return obstacles, windows_all


def _spheres(rng: np.random.Generator, difficulty: float, S: Any, goals: FloatArray, rows: list[dict[str, Any]],
             robot: RobotStart, cfg: CheckConfig, entry: FloatArray, xs: FloatArray) -> list[dict[str, Any]]:
    """One or two spheres between the rows beside the reference path (clear of the rows)."""
    guard = make_guard([S], goals, robot, cfg)
    solid = obstacles_of(rows)
    spread = 0.05 * (1.0 - difficulty) + 0.01
    need = robot.serpentine_radius + cfg.path_margin + 0.005
    arcs = [arc_at(S.path, entry, HEADING, x) for x in xs]

    def sphere() -> dict[str, Any]:
        for _ in range(10):  # one that does not overlap a row
            k = int(rng.integers(0, len(xs) - 1))
            o = ball_between(rng, S.path, arcs[k] + 0.1, arcs[k + 1] - 0.1, need + rng.uniform(0.0, spread),
                             (0.03, 0.07))
            if obstacle_distance(solid, np.array([o["center"]]))[0] > o["radius"] + 0.01:
                break
        return o

    return place(rng, sphere, 1 + int(rng.random() < 0.2 + 0.6 * difficulty), guard)


def family_slot_rack(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                     robot: RobotStart) -> Candidate:
    """A slot rack (module docstring) ahead of the demo robot ``robot``."""
    cfg = sparse_config(cfg)
    L = _draw_layout(rng, difficulty, robot.serpentine_radius - SERPENTINE_RADIUS)
    W = way_through(rng, L, robot, cfg)
    slots, offsets, e, via = W.slots, W.offsets, W.e, W.via
    rows, windows = _rows(rng, L, slots, W.entry, HEADING, W.a, W.n)
    goals = np.array([W.entry, W.entry + L.final * HEADING])
    S = path_samples(robot, via, cfg)
    spheres = _spheres(rng, difficulty, S, goals, rows, robot, cfg, W.entry, L.xs)
    params = {
        "kind": L.kind, "rows": len(L.xs), "roll_deg": round(float(np.degrees(L.roll)), 3),
        "row_positions": [round(float(x), 4) for x in L.xs], "slot_widths": [round(float(w), 4) for w in L.widths],
        "slot_offsets": [round(float(c), 4) for c in slots], "path_offsets": [round(float(v), 4) for v in offsets],
        "pipe_radii": [round(float(r), 4) for r in L.depths] if L.kind == "pipes" else [],
        "windows": windows, "entry_standoff": round(L.standoff, 4), "entry_offset": round(float(e), 4),
        "spheres": len(spheres),
    }
    what = "pipes" if L.kind == "pipes" else "slotted plates"
    gaps = np.diff(L.xs)
    desc = (f"Slot rack: {len(L.xs)} rows of {what} across the approach line, rolled "
            f"{params['roll_deg']:.0f} deg about it, rows {', '.join(f'{g:.2f}' for g in gaps)} m apart; "
            f"the slot near the line ({min(L.widths):.3f}-{max(L.widths):.3f} m) alternates from one side "
            f"to the other, so the straight line is blocked; {len(spheres)} sphere(s) between the rows.  Goals: "
            f"an entry point in front of the rack and the destination behind it, nothing in between.")
    return Candidate(obstacles=rows + spheres, goals=goals, via=via, structure=len(rows), params=params,
                     description=desc, checks=dict(SPARSE_CHECKS), blocked_depth=BLOCKED_DEPTH)
