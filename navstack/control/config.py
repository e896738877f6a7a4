"""Configuration of the slithering controller (:class:`ControlConfig`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from navstack.jpl import ARM_JOINTS, N_JOINTS
from navstack.validate import integer, non_negative, positive

SlitherMode = Literal["projected", "full", "none"]
MODES: dict[str, int] = {"none": 0, "projected": 1, "full": 2}
"""Slithering task forms and their codes in the compiled row builders."""

DEG = math.pi / 180.0


def _floats(v: object) -> np.ndarray:
    """``v`` as a float array; an array of one NaN if it is no array of numbers (a string, None...)."""
    try:
        return np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        return np.full(1, np.nan)


@dataclass(frozen=True)
class ControlConfig:
    """Configuration of :class:`~navstack.control.SlitherController` (units in brackets).

    Weights are the diagonal of ``W`` per task block, gains the diagonal of
    ``K`` [1/s]; ``wv`` is the diagonal of ``W_v`` (20 values, per joint; the
    lathe bed is cheap so insertion comes from it).  ``posture`` is the arm
    posture (7 values [rad] for joints 2..8; ``None``: the arm joints of the
    controller's ``q0``).  ``limit_margin`` [rad] applies to revolute joints,
    ``limit_margin_prismatic`` [m] to the lathe bed.  Each task's own
    parameters are documented with the task (:mod:`navstack.control.tasks`).
    """

    dt: float = 1.0 / 240.0
    """Control period [s]."""
    slither: SlitherMode = "projected"
    w_tip: float = 1.0
    k_tip: float = 20.0
    w_slither: float = 1.0
    k_slither: float = 20.0
    w_posture: float = 1e-2
    k_posture: float = 1.0
    posture: tuple[float, ...] | None = None
    w_limit: float = 1.0
    k_limit: float = 5.0
    limit_margin: float = 10.0 * DEG
    limit_margin_prismatic: float = 0.1
    lambda0: float = 0.01
    lambda_max: float = 0.1
    sigma_eps: float = 0.05
    sigma_every: int = 5
    wv: tuple[float, ...] = (0.01,) + (1.0,) * 7 + (0.1,) * 12
    path_spacing: float = 1e-3
    """Minimum spacing of recorded path vertices [m]."""
    reverse_tolerance: float = 1e-3
    """How far [m] a reverse tip command may be from the recorded path (it should lie on it)."""

    def __post_init__(self) -> None:
        positive(self, "dt", "w_tip", "lambda0", "sigma_eps", "path_spacing", "reverse_tolerance")
        non_negative(self, "k_tip", "w_slither", "k_slither", "w_posture", "k_posture", "w_limit", "k_limit",
                     "limit_margin", "limit_margin_prismatic", "lambda_max")
        for name in ("k_tip", "k_slither", "k_posture", "k_limit"):
            if getattr(self, name) * self.dt > 1.0:
                raise ValueError(
                    f"ControlConfig.{name}={getattr(self, name)} 1/s is too large for dt={self.dt} s "
                    f"(need gain*dt <= 1 for a stable discrete loop)"
                )
        if not isinstance(self.slither, str) or self.slither not in MODES:
            raise ValueError(f"ControlConfig.slither must be one of {sorted(MODES)}, got {self.slither!r}")
        integer(self, "sigma_every", lo=1)
        wv = _floats(self.wv)
        if wv.shape != (N_JOINTS,) or not np.isfinite(wv).all() or (wv <= 0).any():
            raise ValueError(f"ControlConfig.wv must be {N_JOINTS} finite values > 0, got {self.wv!r}")
        if self.posture is not None:
            p = _floats(self.posture)
            if p.shape != (len(ARM_JOINTS),) or not np.isfinite(p).all():
                raise ValueError(
                    f"ControlConfig.posture must be {len(ARM_JOINTS)} finite arm angles [rad] or None, "
                    f"got {self.posture!r}"
                )
