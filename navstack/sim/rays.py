"""PyBullet adapter of the tip proximity sensor: one ``rayTestBatch`` per reading.

The ray pattern, frame convention and noise model are defined in
:mod:`navstack.sensing`; this module only casts the rays in a PyBullet world.

Self hits.  The robot must never see itself.  Two measures:

* every ray starts outside the tip capsule (``ray_start_distances``), so the
  link the sensor is mounted on is never in the way;
* any hit on the body ``robot_id`` (another serpentine link after a sharp
  bend, the arm) is reported as *no hit* (``range = max_range``): the robot
  occludes what lies behind it, and one batch returns only the first hit.

Bullet reports no hit for a ray that *starts inside* a convex shape (checked
for sphere, box, capsule and cylinder in PyBullet 3.2.7), so a ray starting
inside another robot capsule simply passes out of it; one starting inside an
obstacle (the tip already penetrating it) does not see that obstacle either.
"""

from __future__ import annotations

from operator import itemgetter
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from navstack.sensing import (
    SensorConfig,
    SensorReading,
    check_pose,
    ray_directions,
    ray_start_distances,
    reading_from_rays,
)

__all__ = ["RaySensor"]

_BODY = itemgetter(0)
"""The hit body's id in a ``rayTestBatch`` result (-1: no hit)."""
_FRACTION = itemgetter(2)
"""The hit fraction along the ray in a ``rayTestBatch`` result."""


class RaySensor:
    """Casts the tip sensor's rays in a PyBullet world.

    Args:
        client: a ``pybullet_utils.bullet_client.BulletClient`` (or the
            ``pybullet`` module itself) connected to the simulation.
        config: the ray pattern and noise model.
        robot_id: PyBullet body id of the robot whose hits are ignored, or
            ``None`` (a free sensor, e.g. a point robot in tests).
        rng: generator for noise and dropouts (``None`` = exact readings).
    """

    def __init__(
        self,
        client: Any,
        config: SensorConfig,
        robot_id: int | None,
        rng: np.random.Generator | None,
    ) -> None:
        if not isinstance(config, SensorConfig):
            raise TypeError(f"config must be a SensorConfig, got {type(config).__name__}")
        bad_id = isinstance(robot_id, bool) or not isinstance(robot_id, (int, np.integer))
        if robot_id is not None and bad_id:
            raise TypeError(f"robot_id must be an int body id or None, got {robot_id!r}")
        if rng is not None and not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator or None, got {type(rng).__name__}")
        if not hasattr(client, "rayTestBatch"):
            raise TypeError("client must be a PyBullet client (BulletClient or the pybullet module)")
        self.client = client
        self.config = config
        self.robot_id = None if robot_id is None else int(robot_id)
        self.rng = rng
        self._dirs_tip = ray_directions(config)
        self._start = ray_start_distances(config)
        self.n_rays = self._dirs_tip.shape[0]

    def read(self, tip_T_world: ArrayLike) -> SensorReading:
        """Cast every ray from the tip pose ``tip_T_world`` (4, 4, world <- tip frame).

        Exactly one ``client.rayTestBatch`` call (fed numpy arrays: PyBullet reads any sequence of
        3-vectors); returns the (noisy) reading.
        """
        T = check_pose(tip_T_world)
        dirs = self._dirs_tip @ T[:3, :3].T
        tip = T[:3, 3]
        results = self.client.rayTestBatch(tip + self._start[:, None] * dirs, tip + self.config.max_range * dirs)
        if len(results) != self.n_rays:
            raise RuntimeError(f"rayTestBatch returned {len(results)} results for {self.n_rays} rays")
        body = np.fromiter(map(_BODY, results), dtype=np.int64, count=self.n_rays)
        frac = np.fromiter(map(_FRACTION, results), dtype=np.float64, count=self.n_rays)
        hit = body >= 0
        if self.robot_id is not None:
            hit &= body != self.robot_id
        true_ranges = np.where(
            hit, self._start + frac * (self.config.max_range - self._start), self.config.max_range
        )
        return reading_from_rays(tip, dirs, true_ranges, hit, self.config, self.rng)
