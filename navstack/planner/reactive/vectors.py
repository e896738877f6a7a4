"""Small vector helpers of the reactive planner (unit vectors, bounded turns, checked 3-vectors)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def unit(v: NDArray[np.float64], eps: float = 1e-12) -> NDArray[np.float64] | None:
    """``v`` normalised, or None if its norm is below ``eps``."""
    n = float(np.linalg.norm(v))
    return None if n < eps else v / n


def perpendicular(h: NDArray[np.float64]) -> NDArray[np.float64]:
    """A unit vector perpendicular to unit ``h`` (deterministic: crossed with the axis least along it)."""
    ref = np.eye(3)[int(np.argmin(np.abs(h)))]
    p = np.cross(h, ref)
    return p / np.linalg.norm(p)


def along_and_across(P: NDArray[np.float64], x: NDArray[np.float64], u: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points ``P`` (N, 3) [m] seen from ``x`` along unit ``u``: how far along it (N,) [m] and the offset across
    it (N, 3) [m] (the tube tests of the look-ahead, the gap centring and the wall follower)."""
    rel = P - x
    a = rel @ u
    return a, rel - a[:, None] * u


def lateral_preference(h: NDArray[np.float64], e: NDArray[np.float64], pref: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
    """The side to turn to, off unit heading ``h``: the goal's side (unit goal direction ``e``) if it is
    clearly to one side, else ``pref`` (the last look-ahead push), else a fixed perpendicular."""
    lat_goal = e - (e @ h) * h
    if np.linalg.norm(lat_goal) > 0.2:
        pref = lat_goal / np.linalg.norm(lat_goal)
    else:
        p = pref - (pref @ h) * h
        pref = p / np.linalg.norm(p) if np.linalg.norm(p) > 0.3 else perpendicular(h)
    return pref


def rotate_towards(h: NDArray[np.float64], d: NDArray[np.float64], max_angle: float,
                   pref: NDArray[np.float64]) -> NDArray[np.float64]:
    """Turn unit ``h`` towards unit ``d`` by at most ``max_angle`` [rad].

    When ``d`` is opposite to ``h`` the turn goes towards ``pref`` (a lateral direction).
    """
    c = float(np.clip(h @ d, -1.0, 1.0))
    ang = float(np.arccos(c))
    if ang <= max_angle:
        return d.copy()
    axis = np.cross(h, d)
    if np.linalg.norm(axis) < 1e-9:
        axis = np.cross(h, pref)
        if np.linalg.norm(axis) < 1e-9:
            axis = perpendicular(h)
    k = axis / np.linalg.norm(axis)
    out = h * np.cos(max_angle) + np.cross(k, h) * np.sin(max_angle) + k * (k @ h) * (1 - np.cos(max_angle))
    return out / np.linalg.norm(out)


def vec3(value: object, name: str) -> NDArray[np.float64]:
    """A finite 3-vector; TypeError if ``value`` is not numeric at all, ValueError otherwise."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a sequence of 3 numbers, got {type(value).__name__}") from exc
    if arr.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr}")
    return arr.copy()
