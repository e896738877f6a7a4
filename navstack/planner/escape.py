"""Backing out: when no path leads on from where the tip is, retreat along the tip's own path.

A wrong turn into a pocket costs serpentine length for good unless the robot backs out: the
slithering body can only go where the tip has been, and the tip can only turn while it moves.
So when the search finds no way on from the commanded state (every reachable state expanded),
the planner looks for the nearest point *behind* it on its own commanded path from which a way
on exists: candidates every ``step`` [m] back along the path (the state there is the path's point
and forward tangent), nearest first, up to the start of the path; the first one whose search does
leads through every goal is the **branch point**.  The command then runs back along the path to it
(reverse commands: the slithering controller drops the retracted part of its path memory, every
joint point staying on the path), the path record is cut there, and the tip goes forward again on
the new plan.  If no candidate has a way on, the planner gives up (``stalled``).

:class:`CommandPath` is the planner's own record of its commanded tip path: the same vertices the
controller's path memory records (a new vertex once the command is ``spacing`` from the last),
so a point at arc length ``s`` here is on the controller's path too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.planner.search import REACHED, Plan

__all__ = ["CommandPath", "EscapeConfig", "Retreat", "find_branch_point"]


@dataclass(frozen=True)
class EscapeConfig:
    """Parameters of the retreat (metres, seconds).

    Attributes:
        step: spacing of the candidate branch points along the path [m].
        min_back: the first candidate lies this far behind the tip [m].
        max_back: no candidate farther back than this [m].
        speed: retreat speed [m/s].
        accel: retreat acceleration [m/s^2].
    """

    step: float = 0.05
    min_back: float = 0.05
    max_back: float = 1.5
    speed: float = 0.05
    accel: float = 0.1

    def __post_init__(self) -> None:
        for name in ("step", "min_back", "max_back", "speed", "accel"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"EscapeConfig.{name} must be a positive number, got {v!r}")


class CommandPath:
    """Polyline of the commanded tip positions (a vertex once ``spacing`` [m] from the last)."""

    def __init__(self, start: ArrayLike, spacing: float = 1e-3) -> None:
        self._V = np.zeros((4096, 3))
        self._S = np.zeros(4096)
        self._V[0] = np.asarray(start, dtype=np.float64)
        self._n = 1
        self.spacing = float(spacing)

    @property
    def length(self) -> float:
        return float(self._S[self._n - 1])

    @property
    def points(self) -> NDArray[np.float64]:
        return self._V[: self._n].copy()

    def record(self, x: ArrayLike) -> None:
        p = np.asarray(x, dtype=np.float64)
        d = float(np.linalg.norm(p - self._V[self._n - 1]))
        if d < self.spacing:
            return
        if self._n == self._V.shape[0]:
            self._V = np.vstack([self._V, np.zeros_like(self._V)])
            self._S = np.concatenate([self._S, np.zeros_like(self._S)])
        self._V[self._n] = p
        self._S[self._n] = self._S[self._n - 1] + d
        self._n += 1

    def tail(self, length: float, spacing: float = 0.01) -> NDArray[np.float64]:
        """The last ``length`` [m] of the path sampled every ``spacing`` [m], oldest first, ending at its end."""
        end = self.length
        s = np.arange(max(end - length, 0.0), end, spacing)
        return np.array([self.point(x) for x in s] + [self.point(end)])

    def _index(self, s: float) -> tuple[int, float]:
        s = min(max(float(s), 0.0), self.length)
        i = int(np.clip(np.searchsorted(self._S[: self._n], s, side="right") - 1, 0, max(self._n - 2, 0)))
        if self._n == 1:
            return 0, 0.0
        ds = self._S[i + 1] - self._S[i]
        return i, (0.0 if ds <= 0 else (s - self._S[i]) / ds)

    def point(self, s: float) -> NDArray[np.float64]:
        """Position at arc length ``s`` [m] (clamped)."""
        i, f = self._index(s)
        if self._n == 1:
            return self._V[0].copy()
        return self._V[i] + f * (self._V[i + 1] - self._V[i])

    def tangent(self, s: float, span: float = 0.01) -> NDArray[np.float64] | None:
        """Forward unit tangent at ``s`` over about ``span`` [m] behind it (None on a point path)."""
        a = self.point(max(s - span, 0.0))
        b = self.point(max(s, min(span, self.length)))
        d = b - a
        n = float(np.linalg.norm(d))
        return None if n < 1e-9 else d / n

    def truncate(self, s: float) -> None:
        """Drop the path beyond arc length ``s`` (a vertex is put at ``s``)."""
        if s >= self.length:
            return
        i, f = self._index(s)
        p = self._V[i] + f * (self._V[i + 1] - self._V[i]) if self._n > 1 else self._V[0]
        self._n = i + 1
        if f > 0 and float(np.linalg.norm(p - self._V[i])) > 1e-12:
            self._V[self._n] = p
            self._S[self._n] = self._S[i] + float(np.linalg.norm(p - self._V[i]))
            self._n += 1


def find_branch_point(path: CommandPath, plan_from: Callable[[NDArray, NDArray], Plan],
                      config: EscapeConfig, before: float | None = None) -> tuple[float, Plan] | None:
    """The nearest arc length behind the end of ``path`` (and at or before ``before``) from which
    ``plan_from`` finds a complete way on (a plan through every goal).

    ``plan_from(position, heading)`` searches from a state; returns ``(s, plan)`` or None.
    """
    end = path.length if before is None else min(path.length, before + config.min_back)
    back = config.min_back
    while back <= config.max_back + 1e-9:
        s = end - back
        if s < 0.0:
            if back - config.step > end:
                break
            s = 0.0
        t = path.tangent(s)
        if t is not None:
            plan = plan_from(path.point(s), t)
            if plan.status == REACHED:
                return s, plan
        if s == 0.0:
            break
        back += config.step
    return None


class Retreat:
    """Reverse commands along ``path`` from its end back to arc length ``to_s`` [m]."""

    def __init__(self, path: CommandPath, to_s: float, config: EscapeConfig) -> None:
        self.path = path
        self.to_s = float(to_s)
        self.config = config
        self.s = path.length
        self.v = 0.0

    @property
    def done(self) -> bool:
        return self.s <= self.to_s + 1e-9

    def step(self, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Move back by one period; the new position and the (backward) velocity [m/s]."""
        cfg = self.config
        remaining = self.s - self.to_s
        v = min(cfg.speed, self.v + cfg.accel * dt, math.sqrt(2.0 * cfg.accel * max(remaining, 0.0)))
        v = max(v, min(remaining / dt, 1e-3))  # never stall short of the branch point
        s_new = max(self.s - v * dt, self.to_s)
        self.v = (self.s - s_new) / dt
        p_old = self.path.point(self.s)
        self.s = s_new
        p = self.path.point(self.s)
        d = p - p_old
        n = float(np.linalg.norm(d))
        vel = d / n * self.v if n > 1e-12 else np.zeros(3)
        return p, vel
