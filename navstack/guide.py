"""The goal spline: a smooth curve through the goals, from goals and the robot's state only.

A cubic spline from the start tip position through every goal, parameterised
by chord length, leaving the start along the tip's heading (clamped first
derivative) and ending free (natural end condition).  It is resampled every
``sample`` metres of parameter (about that much arc length) and carries its
cumulative arc length, its smallest radius of curvature and the arc length at
each goal.

Three users:

* :class:`navstack.scripted.ScriptedPlanner` (the blind baseline) follows it;
* :class:`navstack.planner.reactive.PotentialFieldPlanner` pursues it as the *guide*
  of its attraction, so the tip arrives at each goal already turned towards
  the next one, and deviates from it where the sensors say so;
* :mod:`navstack.generate` checks that a generated world's reference path
  (this curve through its via points) is free and smooth enough.

It knows nothing of obstacles.  Units: metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline

__all__ = ["GuidePath", "goal_spline"]


@dataclass(frozen=True)
class GuidePath:
    """A sampled curve through the goals.

    Attributes:
        points: (N, 3) samples [m], ``points[0]`` the start.
        arc: (N,) cumulative arc length at each sample [m], ``arc[0] = 0``.
        min_turn_radius: smallest radius of curvature of the spline [m].
        goals: (k, 3) the goals the curve was built through [m].
        goal_arcs: (k,) arc length at each goal [m] (non-decreasing).
    """

    points: NDArray[np.float64]
    arc: NDArray[np.float64]
    min_turn_radius: float
    goals: NDArray[np.float64]
    goal_arcs: NDArray[np.float64]

    @property
    def length(self) -> float:
        """Total arc length [m]."""
        return float(self.arc[-1])

    def point(self, s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Position (3,) [m] and unit tangent (3,) at arc length ``s`` (clamped to the curve)."""
        s = min(max(float(s), 0.0), self.length)
        i = int(np.clip(np.searchsorted(self.arc, s) - 1, 0, len(self.arc) - 2))
        ds = self.arc[i + 1] - self.arc[i]
        f = 0.0 if ds <= 0 else (s - self.arc[i]) / ds
        d = self.points[i + 1] - self.points[i]
        return self.points[i] + f * d, d / max(float(ds), 1e-12)

    def positions(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Positions (n, 3) [m] at the arc lengths ``s`` (n,) (clamped to the curve), vectorised."""
        s = np.clip(s, 0.0, self.length)
        return np.stack([np.interp(s, self.arc, self.points[:, k]) for k in range(3)], axis=1)

    def project(self, x: ArrayLike, s_lo: float, s_hi: float) -> tuple[float, float]:
        """Arc length of the sample nearest to ``x`` within ``[s_lo, s_hi]``, and its distance [m].

        Only the samples in the window are searched, so a caller that moves the
        window forward with its own progress pays O(window) per call.
        """
        lo = int(np.searchsorted(self.arc, max(s_lo, 0.0), side="left"))
        hi = int(np.searchsorted(self.arc, min(s_hi, self.length), side="right"))
        lo = min(lo, len(self.arc) - 1)
        hi = max(hi, lo + 1)
        d2 = ((self.points[lo:hi] - np.asarray(x, dtype=np.float64)) ** 2).sum(axis=1)
        j = int(np.argmin(d2))
        return float(self.arc[lo + j]), float(np.sqrt(d2[j]))


def goal_spline(start: ArrayLike, heading: ArrayLike, goals: ArrayLike, sample: float = 0.002) -> GuidePath:
    """The cubic spline from ``start`` along ``heading`` through ``goals`` (k, 3), sampled every ``sample`` m.

    Goals that coincide with the previous point are skipped for the fit (their
    arc length is the previous one's).

    Raises:
        ValueError: wrong shapes, non-finite values, a zero heading or a non-positive ``sample``.
    """
    p0 = np.asarray(start, dtype=np.float64)
    h = np.asarray(heading, dtype=np.float64)
    g = np.atleast_2d(np.asarray(goals, dtype=np.float64))
    if p0.shape != (3,) or h.shape != (3,) or g.ndim != 2 or g.shape[1] != 3 or len(g) == 0:
        raise ValueError(
            f"goal_spline needs start (3,), heading (3,) and goals (k, 3), got {p0.shape}, {h.shape}, {g.shape}"
        )
    if not (np.isfinite(p0).all() and np.isfinite(h).all() and np.isfinite(g).all()):
        raise ValueError("goal_spline: start, heading and goals must be finite")
    if isinstance(sample, bool) or not (np.isfinite(sample) and sample > 0):
        raise ValueError(f"goal_spline: sample must be a positive length [m], got {sample!r}")
    hn = float(np.linalg.norm(h))
    if hn < 1e-12:
        raise ValueError("goal_spline: heading must be non-zero")
    knots = [p0]
    knot_of_goal = []
    for q in g:
        if np.linalg.norm(q - knots[-1]) > 1e-6:
            knots.append(q)
        knot_of_goal.append(len(knots) - 1)
    if len(knots) < 2:
        knots.append(p0 + 1e-3 * h / hn)
    P = np.array(knots)
    u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    spline = CubicSpline(u, P, bc_type=((1, h / hn), (2, np.zeros(3))))
    fine = np.linspace(0.0, u[-1], max(int(np.ceil(u[-1] / (sample / 4))), 8) + 1)
    d1 = spline(fine, 1)
    d2 = spline(fine, 2)
    speed = np.linalg.norm(d1, axis=1)
    curv = np.linalg.norm(np.cross(d1, d2), axis=1) / np.maximum(speed**3, 1e-12)
    uu = np.linspace(0.0, u[-1], max(int(np.ceil(u[-1] / sample)), 2) + 1)
    xyz = spline(uu)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))])
    goal_arcs = np.interp(u[knot_of_goal], uu, arc)
    return GuidePath(
        points=xyz,
        arc=arc,
        min_turn_radius=float(1.0 / max(curv.max(), 1e-12)),
        goals=g.copy(),
        goal_arcs=goal_arcs,
    )
