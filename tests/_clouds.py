"""Synthetic point clouds for the planner's unit tests (sensed surfaces without a simulator)."""

from __future__ import annotations

import numpy as np


def box_surface(centre, a: float, spacing: float = 0.01) -> np.ndarray:
    """Points on the six faces of the cube of half side ``a`` [m] round ``centre``, ``spacing`` apart."""
    g = np.arange(-a, a + 1e-9, spacing)
    u, v = (x.ravel() for x in np.meshgrid(g, g, indexing="ij"))
    faces = []
    for ax in range(3):
        for s in (-a, a):
            f = np.zeros((len(u), 3))
            f[:, ax] = s
            f[:, (ax + 1) % 3] = u
            f[:, (ax + 2) % 3] = v
            faces.append(np.asarray(centre, dtype=float) + f)
    return np.vstack(faces)
