"""``duct-elbow``: inside a square duct that bends; the goal only at its far end.

An inspection robot's commonest confined task: enter a duct and follow it round an elbow.  The way:
straight from the tip, an arc of radius 0.35-0.5 m turning up to 10 + 15 d deg towards a random
direction (so the mouth need not lie on the heading), 0.12-0.2 m straight along the duct's axis to the
mouth (0.3-0.4 m of way from the tip, or more), 0.05-0.15 m more inside, then the **elbow**: an arc of
radius R by A towards a random direction across the axis, then straight to the goal, 0.06-0.1 m before the
duct's end (closed by a plate, or open, at random).  The duct's inside is 2 h x 2 h, its cross-section
rolled at random about its axis; its walls (5-15 mm) are one box per wall along each straight run and,
along the elbow, one box per wall for every chord of about 4 cm, lengthened to close the outer seams.
Sensing sees walls on every side; the tip must turn within the duct before its outer wall, and every link
must follow it round.  The goal alone does not mark the way: the mouth and the elbow are the planner's to
find.

Difficulty d (0..1): half width 0.1 -> 0.075 m (minus up to 5 mm), elbow 45-70 -> 75-100 deg with radius
0.42-0.5 -> 0.3-0.38 m, more approach tilt.  Units: metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from navstack.generate.base import HEADING, TIP, Candidate
from navstack.generate.checks import CheckConfig, RobotStart
from navstack.generate.geometry import FloatArray, perpendicular
from navstack.generate.sparse import BLOCKED_DEPTH, SPARSE_CHECKS, box_on_axes, sparse_config

__all__ = ["curve", "duct_walls", "family_duct_elbow"]

CHORD = 0.04
"""Target chord length [m] of the elbow's wall boxes."""


def curve(pieces: list[tuple[float, float, FloatArray | None]], step: float = 0.05
          ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Samples (every ``step`` [m] or less) of a curve from :data:`TIP` along :data:`HEADING`.

    Each piece is ``(length, radius, b)``: straight for ``radius == 0``, else an arc of ``radius`` turning
    towards the unit ``b`` (made perpendicular to the heading there).  Returns the points, their unit
    tangents and their arc lengths.
    """
    p, h = TIP.astype(float), HEADING.astype(float)
    pts, tans, arcs, s0 = [p], [h], [0.0], 0.0
    for length, radius, b in pieces:
        n = max(1, int(np.ceil(length / step)))
        v = np.linspace(length / n, length, n)[:, None]
        if radius == 0.0:
            pts.extend(p + v * h)
            tans.extend(np.repeat(h[None], n, axis=0))
        else:
            b = b - (b @ h) * h
            b = b / np.linalg.norm(b)
            phi = v / radius
            pts.extend(p + radius * (b + np.sin(phi) * h - np.cos(phi) * b))
            tans.extend(np.cos(phi) * h + np.sin(phi) * b)
        arcs.extend(s0 + v[:, 0])
        p, h, s0 = pts[-1], tans[-1], s0 + length
    return np.array(pts), np.array(tans), np.array(arcs)


def _walls(mid: FloatArray, t: FloatArray, e1: FloatArray, half_len: float, h: float,
           wall: float) -> list[dict[str, Any]]:
    """Four wall boxes around a run of the duct centred at ``mid`` along ``t`` (cross axes ``e1``,
    ``t x e1``), inside half width ``h``."""
    e2 = np.cross(t, e1)
    axes = np.column_stack([t, e1, e2])
    out = []
    for s in (-1.0, 1.0):
        out.append(box_on_axes(mid + s * (h + wall / 2) * e1, axes, (half_len, wall / 2, h + wall)))
        out.append(box_on_axes(mid + s * (h + wall / 2) * e2, axes, (half_len, h, wall / 2)))
    return out


def duct_walls(pts: FloatArray, tans: FloatArray, arcs: FloatArray, s_mouth: float, s_end: float,
               bend: tuple[float, float], h: float, wall: float, roll: float, normal: FloatArray,
               closed: bool) -> list[dict[str, Any]]:
    """The walls of the duct along the curve (:func:`curve`) from arc length ``s_mouth`` to ``s_end``
    [m]; ``bend`` the elbow's arc-length span [m]; ``normal`` the elbow plane's unit normal."""

    def at(s: float) -> FloatArray:
        return _at(pts, arcs, s)

    def cross_axis(t: FloatArray) -> FloatArray:
        e1 = np.cross(normal, t)
        e1 /= np.linalg.norm(e1)
        return np.cos(roll) * e1 + np.sin(roll) * np.cross(t, e1)

    out: list[dict[str, Any]] = []
    corner = np.sqrt(2.0) * (h + wall)
    for a, b_ in ((s_mouth, bend[0]), (bend[1], s_end)):  # the straight runs
        if b_ - a > 1e-6:
            t = at(b_) - at(a)
            t /= np.linalg.norm(t)
            out += _walls(0.5 * (at(a) + at(b_)), t, cross_axis(t), 0.5 * (b_ - a), h, wall)
    n = max(1, int(np.ceil((bend[1] - bend[0]) / CHORD)))
    knots = np.linspace(bend[0], bend[1], n + 1)
    for a, b_ in zip(knots[:-1], knots[1:], strict=True):
        pa, pb = at(a), at(b_)
        t = pb - pa
        chord = float(np.linalg.norm(t))
        t /= chord
        ext = 0.5 * corner * _angle(tans, arcs, a, b_) + 0.003  # closes the outer seam
        out += _walls(0.5 * (pa + pb), t, cross_axis(t), 0.5 * chord + ext, h, wall)
    if closed:
        t = tans[np.searchsorted(arcs, s_end) - 1]
        e1 = cross_axis(t)
        axes = np.column_stack([t, e1, np.cross(t, e1)])
        out.append(box_on_axes(at(s_end) + 0.5 * wall * t, axes, (wall / 2, h + wall, h + wall)))
    return out


def _at(values: FloatArray, arcs: FloatArray, s: ArrayLike) -> FloatArray:
    """``values`` (n, 3) sampled at arc lengths ``arcs`` (n,), interpolated at ``s`` [m]."""
    return np.stack([np.interp(s, arcs, values[:, i]) for i in range(3)], axis=-1)


def _angle(tans: FloatArray, arcs: FloatArray, a: float, b: float) -> float:
    """Angle [rad] the tangent turns between arc lengths ``a`` and ``b``."""
    ta, tb = _at(tans, arcs, a), _at(tans, arcs, b)
    c = ta @ tb / (np.linalg.norm(ta) * np.linalg.norm(tb))
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def family_duct_elbow(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                      robot: RobotStart) -> Candidate:
    """A duct with an elbow (module docstring) ahead of the demo robot ``robot``."""
    d = difficulty
    cfg = sparse_config(cfg)
    tilt = np.radians(rng.uniform(0.0, 10.0 + 15.0 * d))
    b1 = perpendicular(rng, HEADING)
    r1 = rng.uniform(0.35, 0.5)
    lead = rng.uniform(0.12, 0.2)
    inside = rng.uniform(0.05, 0.15)
    h = max(0.07, 0.1 - 0.025 * d - rng.uniform(0.0, 0.005))
    angle = np.radians(rng.uniform(45.0, 70.0) + 30.0 * d)
    r2 = rng.uniform(0.42, 0.5) - 0.12 * d
    after = rng.uniform(0.1, 0.2)
    tail = rng.uniform(0.06, 0.1)
    straight = max(0.05, rng.uniform(0.3, 0.4) - r1 * tilt - lead)
    w = np.cos(tilt) * HEADING + np.sin(tilt) * b1  # the duct's axis at its mouth
    b2 = perpendicular(rng, w)
    pieces = [(straight, 0.0, None), (r1 * tilt, r1, b1), (lead + inside, 0.0, None), (r2 * angle, r2, b2),
              (after + tail, 0.0, None)]
    pts, tans, arcs = curve([p for p in pieces if p[0] > 1e-9], step=0.005)
    s_mouth = straight + r1 * tilt + lead
    bend = (s_mouth + inside, s_mouth + inside + r2 * angle)
    s_end = float(arcs[-1])
    s_goal = s_end - tail
    goal = _at(pts, arcs, s_goal)
    normal = np.cross(w, b2)
    normal /= np.linalg.norm(normal)
    wall = rng.uniform(0.005, 0.015)
    roll = rng.uniform(0.0, np.pi / 2)
    closed = bool(rng.random() < 0.5)
    duct = duct_walls(pts, tans, arcs, s_mouth, s_end, bend, h, wall, roll, normal, closed)
    s_via = np.arange(0.05, s_goal - 0.025, 0.05)
    via = np.vstack([_at(pts, arcs, s_via), goal[None]])
    params = {
        "half_width": round(float(h), 4), "elbow_deg": round(float(np.degrees(angle)), 3),
        "elbow_radius": round(float(r2), 4), "tilt_deg": round(float(np.degrees(tilt)), 3),
        "wall": round(float(wall), 4), "roll_deg": round(float(np.degrees(roll)), 3), "closed": closed,
        "mouth_ahead": round(float(s_mouth), 4),
    }
    desc = (f"Duct elbow: a {2 * h:.2f} m square duct, its mouth {s_mouth:.2f} m of way ahead, bending "
            f"{params['elbow_deg']:.0f} deg (radius {r2:.2f} m) inside; the goal {tail:.2f} m before its "
            f"{'closed' if closed else 'open'} end.")
    return Candidate(obstacles=duct, goals=goal[None], via=via, structure=len(duct), params=params,
                     description=desc, checks=dict(SPARSE_CHECKS), blocked_depth=BLOCKED_DEPTH)
