"""``fin-bank``: banks of thin fins seen edge-on; the goals do not mark the channel to take.

Two banks across the approach line (the tip's heading) from the entry goal to the final goal.  Each bank
is a row of parallel fins: flat plates 1.5-8 mm thick, 5-10 cm deep along the line and 0.9-1.2 m long,
whose faces are parallel to the line, so the tip meets their thin leading edges head-on and sees their
faces only at grazing angles (the case a ray sensor finds hardest).  The fins of a bank are spaced so
that every channel between two of them is one width (surface to surface, 0.12-0.15 m); the whole set is
rolled about the line by a random angle (fins vertical, horizontal or oblique).  As in ``slot-rack``
(whose layout and reference profile this family shares, :mod:`navstack.generate.slot_rack`), the channel
each bank offers near the line alternates from one side of it to the other, so the straight line comes
within the tip's radius of a fin in every bank: going straight collides, and the way jogs sideways
between the banks.  Up to three cables (radius 5-10 mm, 0.4-1 m long, parallel to the fins and so across the
way) hang between the banks beside the reference path, at least 5 mm from every fin.

Goals: only an entry goal 0.15-0.23 m before the first bank's leading edges and the final goal on the line
0.18-0.28 m behind the last bank's trailing edges.

The path runs straight through each bank and 3-6 cm beyond its fins at either end (links entering a
channel on a curve would cut 12 mm into its fins).  A third bank does not fit the robot's reach: its arm
would enter the first bank (the length rule of :mod:`navstack.generate`).

Difficulty d (0..1): fins U(3 - 1.5 d, 8 - 4 d) mm thick (per bank); the S-curve between the banks drawn
U(0.36 - 0.1 d, 0.45 - 0.1 d) m long (the fins 6-12 cm farther apart than that); channel width 0.15 - 0.03 d m
(minus up to 5 mm; each bank's own within 3 mm of it, all in [0.12, 0.15] m); round(2 d) cables plus one
on a coin toss, each with its surface 0.045 + (0.04 (1 - d) + 0.01) x U(0, 1) m from the tip's path (at
least 20 mm from the tip's surface).  Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.generate.base import HEADING, Candidate, Guard, make_guard, place
from navstack.generate.checks import CheckConfig, RobotStart, Samples, path_samples
from navstack.generate.geometry import FloatArray, cylinder_dict, obstacle_distance, segment_samples
from navstack.generate.slot_rack import Layout, row_offsets, way_through
from navstack.generate.sparse import (
    BLOCKED_DEPTH,
    SPARSE_CHECKS,
    arc_at,
    box_on_axes,
    obstacles_of,
    sparse_config,
)

__all__ = ["family_fin_bank", "fin_row"]


def fin_row(centre: FloatArray, u: FloatArray, a: FloatArray, n: FloatArray, slot: float, width: float,
            thickness: float, depth: float, half_length: float) -> list[dict[str, Any]]:
    """Fins (boxes ``thickness`` [m] along ``n``, ``2 depth`` along ``u``, ``2 half_length`` along ``a``)
    spaced along ``n`` as a slot rack's row (:func:`~navstack.generate.slot_rack.row_offsets`): every channel
    between two fins is ``width`` [m] surface to surface and one is centred ``slot`` [m] from ``centre``."""
    axes = np.column_stack([u, a, n])
    half = (depth, half_length, thickness / 2.0)
    return [box_on_axes(centre + o * n, axes, half) for o in row_offsets(slot, width, thickness)]


def _draw_layout(rng: np.random.Generator, difficulty: float) -> Layout:
    """Banks at ``xs`` (their mid planes, from the entry goal along the line), ``depths`` the fins' half
    depth and ``halves`` the straight stretch of the path around each bank [m]."""
    n_rows = 2  # a third bank does not fit: the arm would reach into the first (length rule)
    depths = rng.uniform(0.025, 0.05, size=n_rows)
    halves = depths + rng.uniform(0.03, 0.06, size=n_rows)  # links entering a channel straight keep 12 mm
    free = rng.uniform(0.36 - 0.1 * difficulty, 0.45 - 0.1 * difficulty, size=n_rows - 1)
    width = max(0.12, 0.15 - 0.03 * difficulty - rng.uniform(0.0, 0.005))
    widths = np.clip(width + rng.uniform(-0.003, 0.003, size=n_rows), 0.12, 0.15)
    first = halves[0] + rng.uniform(0.12, 0.17)
    xs = first + np.concatenate([[0.0], np.cumsum(halves[:-1] + free + halves[1:])])
    return Layout(kind="fins", xs=xs, halves=halves, widths=widths, depths=depths,
                  standoff=float(rng.uniform(0.22, 0.32)), final=float(xs[-1] + halves[-1] + rng.uniform(0.15, 0.22)),
                  roll=float(rng.uniform(0.0, np.pi)))


def _cables(rng: np.random.Generator, difficulty: float, L: Layout, S: Samples, fins: list[dict[str, Any]],
            guard: Guard, a: FloatArray, entry: FloatArray, need: float) -> list[dict[str, Any]]:
    """round(2 d) cables, plus one on a coin toss: radius 5-10 mm, 0.4-1 m long along the fins' length ``a``
    (across the way, parallel to the fins), hung between the banks beside the reference path (``S``) in the
    plane the way jogs in, their surface ``need`` + U(0, 0.04 (1 - d) + 0.01) [m] from the tip's path; a draw
    that comes within 5 mm of a fin, or that ``guard`` refuses (the way's clearances), is drawn again (up to 25
    times)."""
    solid = obstacles_of(fins)
    arcs = [arc_at(S.path, entry, HEADING, x) for x in L.xs]
    idx = np.flatnonzero((S.path.arc >= arcs[0] + L.halves[0] + 0.03) & (S.path.arc <= arcs[1] - L.halves[1] - 0.03))
    spread = 0.04 * (1.0 - difficulty) + 0.01
    last = len(S.path.points) - 1

    def cable() -> dict[str, Any]:
        i = int(rng.choice(idx))
        side = np.cross(S.path.points[min(i + 1, last)] - S.path.points[max(i - 1, 0)], a)
        r = rng.uniform(0.005, 0.01)
        dist = (need + rng.uniform(0.0, spread) + r) * (1.0 if rng.random() < 0.5 else -1.0)
        c = S.path.points[i] + dist * side / np.linalg.norm(side) + rng.uniform(-0.1, 0.1) * a
        half = rng.uniform(0.2, 0.5)
        return cylinder_dict(c - half * a, c + half * a, r)

    def off_the_fins(o: dict[str, Any]) -> bool:
        axis = segment_samples(np.array([o["p0"]]), np.array([o["p1"]]), 0.01)
        return bool(obstacle_distance(solid, axis).min() > o["radius"] + 0.005)

    return place(rng, cable, int(round(2 * difficulty)) + int(rng.random() < 0.5), guard, ok=off_the_fins)


def family_fin_bank(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                    robot: RobotStart) -> Candidate:
    """A fin bank (module docstring) ahead of the demo robot ``robot``."""
    cfg = sparse_config(cfg)
    L = _draw_layout(rng, difficulty)
    W = way_through(rng, L, robot, cfg)  # the channels are the rack's slots
    u, a, n, entry, slots, via = HEADING, W.a, W.n, W.entry, W.slots, W.via
    thickness = rng.uniform(0.003 - 0.0015 * difficulty, 0.008 - 0.004 * difficulty, size=len(L.xs))
    half_length = rng.uniform(0.45, 0.6)
    shift = rng.uniform(-0.05, 0.05)  # of the banks along a
    fins: list[dict[str, Any]] = []
    for k, x in enumerate(L.xs):
        fins += fin_row(entry + x * u + shift * a, u, a, n, float(slots[k]), float(L.widths[k]),
                        float(thickness[k]), float(L.depths[k]), half_length)
    goals = np.array([entry, entry + L.final * u])
    S = path_samples(robot, via, cfg)
    cables = _cables(rng, difficulty, L, S, fins, make_guard([S], goals, robot, cfg), a, entry,
                     robot.serpentine_radius + cfg.path_margin + 0.005)
    params = {
        "banks": len(L.xs), "roll_deg": round(float(np.degrees(L.roll)), 3),
        "bank_positions": [round(float(x), 4) for x in L.xs],
        "fin_half_depths": [round(float(d), 4) for d in L.depths],
        "fin_thicknesses": [round(float(t), 4) for t in thickness],
        "channel_widths": [round(float(w), 4) for w in L.widths],
        "channel_offsets": [round(float(c), 4) for c in slots], "path_offsets": [round(float(v), 4) for v in W.offsets],
        "entry_standoff": round(L.standoff, 4), "entry_offset": round(W.e, 4), "cables": len(cables),
    }
    gaps = np.diff(L.xs)
    desc = (f"Fin bank: {len(L.xs)} banks of thin fins ({1000 * min(thickness):.0f}-{1000 * max(thickness):.0f} mm) "
            f"edge-on to the approach line, rolled {params['roll_deg']:.0f} deg about it, banks "
            f"{', '.join(f'{g:.2f}' for g in gaps)} m apart; the channel near the line "
            f"({min(L.widths):.3f}-{max(L.widths):.3f} m) alternates from one side to the other, so the straight "
            f"line grazes a fin; {len(cables)} cable(s) between the banks.  Goals: an entry point in front of the "
            f"fins and the destination behind them, nothing in between.")
    return Candidate(obstacles=fins + cables, goals=goals, via=via, structure=len(fins), params=params,
                     description=desc, checks=dict(SPARSE_CHECKS), blocked_depth=BLOCKED_DEPTH)
