"""The robot at ``q0`` among a world's obstacles at t = 0 in a fresh PyBullet client: the scene a trial starts
from (:func:`build_scene`: ``navstack.trial.run_trial`` checks the start in it, then simulates in it;
``navstack.trial.check_start`` on its own builds one and drops it), and :func:`start_scene`, a throwaway one
for ``navstack.generate.checks.start_clearance`` before a generated world is used.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

from navstack.jpl import jpl_serpentine


def build_scene(world: Any, visuals: bool = False) -> tuple[Any, Any, Any]:
    """``(client, body, scene)``: a fresh DIRECT client holding a :class:`~navstack.sim.body.RobotBody` at
    ``world.robot.q0`` and the world's :class:`~navstack.sim.scene.Scene` (``visuals``: with visual shapes).
    The caller disconnects the client (it is disconnected here if building fails)."""
    from navstack.sim._bullet import direct_client
    from navstack.sim.body import RobotBody
    from navstack.sim.scene import Scene, SceneOptions

    client = direct_client()
    try:
        body = RobotBody.build(client, jpl_serpentine(), world.robot.base.transform(),
                               serpentine_radius=world.robot.serpentine_radius, arm_radius=world.robot.arm_radius,
                               visuals=visuals)
        body.reset(world.robot.q0)
        scene = Scene.build(client, world, SceneOptions(visuals=visuals))
    except BaseException:
        client.disconnect()
        raise
    return client, body, scene


@contextlib.contextmanager
def start_scene(world: Any) -> Iterator[tuple[Any, Any]]:
    """Yield ``(body, scene)`` of :func:`build_scene` (collision shapes only), collision detection run; the
    client is disconnected when the ``with`` block ends."""
    client, body, scene = build_scene(world)
    try:
        client.performCollisionDetection()
        yield body, scene
    finally:
        client.disconnect()
