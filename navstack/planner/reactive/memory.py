"""The reactive planner's point memory: obstacle points seen so far, one per voxel."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["PointMemory"]


class PointMemory:
    """Obstacle points seen so far, one per voxel (world frame, metres).

    Each voxel keeps the running mean of the points that fell in it (static
    obstacles: averaging removes range noise), over at most ``average``
    samples (then an exponential average with weight ``1/average``, so a stale
    estimate is still replaced).  Beyond ``capacity`` voxels the points
    farthest from the last query position are dropped.
    """

    def __init__(self, voxel: float, capacity: int, average: int = 10) -> None:
        if not (np.isfinite(voxel) and voxel > 0):
            raise ValueError(f"voxel must be a positive size in metres, got {voxel!r}")
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity!r}")
        if average < 1:
            raise ValueError(f"average must be >= 1, got {average!r}")
        self.voxel = float(voxel)
        self.capacity = int(capacity)
        self.average = int(average)
        self._index: dict[tuple[int, int, int], int] = {}
        self._pts = np.empty((min(1024, self.capacity), 3))
        self._cnt = np.zeros(self._pts.shape[0], dtype=np.int64)
        self._n = 0
        self._last_query = np.zeros(3)

    def __len__(self) -> int:
        return self._n

    @property
    def points(self) -> NDArray[np.float64]:
        """All stored points (N, 3) [m] (a copy)."""
        return self._pts[: self._n].copy()

    def add(self, pts: NDArray[np.float64]) -> None:
        """Store points (K, 3) [m]."""
        pts = np.asarray(pts, dtype=np.float64).reshape(-1, 3)
        if pts.shape[0] == 0:
            return
        keys = np.floor(pts / self.voxel).astype(np.int64)
        for key_arr, p in zip(keys, pts, strict=True):
            key = (int(key_arr[0]), int(key_arr[1]), int(key_arr[2]))
            idx = self._index.get(key)
            if idx is not None:
                c = min(int(self._cnt[idx]) + 1, self.average)
                self._cnt[idx] = c
                self._pts[idx] += (p - self._pts[idx]) / c
                continue
            if self._n == self.capacity:
                self._drop_far()
            if self._n == self._pts.shape[0]:
                size = min(2 * self._pts.shape[0], self.capacity)
                grown = np.empty((size, 3))
                grown[: self._n] = self._pts[: self._n]
                cnt = np.zeros(size, dtype=np.int64)
                cnt[: self._n] = self._cnt[: self._n]
                self._pts, self._cnt = grown, cnt
            self._pts[self._n] = p
            self._cnt[self._n] = 1
            self._index[key] = self._n
            self._n += 1

    def _drop_far(self) -> None:
        keep_n = max(self.capacity // 2, 1)
        d = np.linalg.norm(self._pts[: self._n] - self._last_query, axis=1)
        keep = np.sort(np.argsort(d, kind="stable")[:keep_n])
        self._pts[:keep_n] = self._pts[keep]
        self._cnt[:keep_n] = self._cnt[keep]
        self._n = keep_n
        self._index = {}
        keys = np.floor(self._pts[: self._n] / self.voxel).astype(np.int64)
        for i, k in enumerate(keys):
            self._index[(int(k[0]), int(k[1]), int(k[2]))] = i

    def near(self, x: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
        """Stored points within ``radius`` [m] of ``x`` (M, 3)."""
        self._last_query = np.array(x, dtype=np.float64)
        if self._n == 0:
            return np.empty((0, 3))
        P = self._pts[: self._n]
        d2 = np.sum((P - x) ** 2, axis=1)
        return P[d2 <= radius * radius].copy()

