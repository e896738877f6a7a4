"""Retreat: tip commands that run back along a recorded path (reverse slithering).

A :class:`Retreat` drives the tip backwards along a :class:`~navstack.path.PathMemory`, from the path's
end (:attr:`~navstack.path.PathMemory.end_arc_length` when the retreat is made) down to an arc length
``to_arc_length``, with a trapezoidal speed profile: from rest, accelerating at ``accel`` [m/s^2] up to
``speed`` [m/s], and braking at ``accel`` to stop exactly on the target: the speed changes by at most
``accel * dt`` per step, braking included, except on the step that lands on the target (at most
``1.125 accel dt``: the braking curve meets the target between two steps).  Each :meth:`Retreat.step` returns
a :class:`~navstack.planner.TipCommand` with ``reverse=True``: its position is the path's point at the new
arc length (on the recorded path, behind its end), its velocity ``-v`` times the path's unit tangent there.
Given to the slithering controller, such a command cuts the controller's path memory back instead of
recording it, so every serpentine joint point retraces the way it came.

Used by the trial to retract after the last goal (``"retract": true`` worlds) and by a planner to back out
of a dead end.  Positions and velocities are in the frame of the path memory it is given (the
controller's: the robot's base frame).  Pure numpy; the path must not be cut back below the retreat's
current arc length by anyone else while it runs.

    retreat = Retreat(controller.path, controller.path.start_arc_length, speed=0.06, accel=0.1)
    while not retreat.done:
        cmd = retreat.step(dt)          # cmd.reverse is True
"""

from __future__ import annotations

import math

import numpy as np

from navstack.path import MIN_ARC, PathMemory


class Retreat:
    """Reverse tip commands along ``path`` down to ``to_arc_length`` [m] (see the module docstring).

    ``speed`` [m/s] is the cruise speed, ``accel`` [m/s^2] the acceleration and braking; the retreat
    starts from rest at the path's current end.
    """

    def __init__(self, path: PathMemory, to_arc_length: float, speed: float, accel: float) -> None:
        from navstack.planner import TipCommand  # here, so that the planner may import this module

        if not isinstance(path, PathMemory):
            raise TypeError(f"path must be a PathMemory, got {type(path).__name__}")
        end = path.end_arc_length
        for name, value in (("speed", speed), ("accel", accel)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0:
                raise ValueError(f"Retreat: {name} must be a positive number, got {value!r}")
        if not (isinstance(to_arc_length, (int, float)) and math.isfinite(to_arc_length)
                and MIN_ARC < to_arc_length <= end):
            raise ValueError(f"Retreat: to_arc_length must be in ({MIN_ARC}, {end}] m (the path's end), "
                             f"got {to_arc_length!r}")
        self.path = path
        self.to_arc_length = float(to_arc_length)
        self.speed = float(speed)
        self.accel = float(accel)
        self._command = TipCommand
        self._s = end
        self._v = 0.0

    @property
    def arc_length(self) -> float:
        """Arc length [m] of the last command (the path's end before the first step)."""
        return self._s

    @property
    def speed_now(self) -> float:
        """Speed [m/s] of the last command (>= 0, backwards along the path)."""
        return self._v

    @property
    def remaining(self) -> float:
        """Arc length [m] still to go back."""
        return self._s - self.to_arc_length

    @property
    def done(self) -> bool:
        """True once a command has reached ``to_arc_length`` (the tip is then told to stop there)."""
        return self._s <= self.to_arc_length

    def step(self, dt: float):
        """The command for the end of the next period ``dt`` [s]: a ``TipCommand`` with ``reverse=True``.

        Position: the path's point at the new arc length; velocity: the speed over the period times the
        unit tangent, pointing back along the path.  After :attr:`done` the command holds the target at rest.
        """
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive period [s], got {dt!r}")
        remaining = max(self._s - self.to_arc_length, 0.0)
        # the fastest v from which steps slowing by accel * dt still stop by the target:
        # remaining - v dt >= v (v - a dt) / (2 a), i.e. v^2 + a dt v <= 2 a remaining
        adt = self.accel * dt
        v_brake = 0.5 * (math.sqrt(adt * adt + 8.0 * self.accel * remaining) - adt)
        v = min(self.speed, self._v + adt, v_brake)
        s = self._s - v * dt
        if s <= self.to_arc_length + 1e-12:
            s, v = self.to_arc_length, 0.0 if remaining <= 1e-12 else remaining / dt
        self._s, self._v = s, v
        p, t = self.path.point_at(s)
        velocity = -v * t if v > 0.0 else np.zeros(3)
        return self._command(position=p, velocity=velocity, stalled=False, mode="retreat", reverse=True)
