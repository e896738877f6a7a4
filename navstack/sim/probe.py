"""The robot at ``q0`` among a world's obstacles at t = 0, in a throwaway PyBullet client, for the checks made
before a trial (``navstack.trial.check_start``) and before a generated world is used
(``navstack.generate.checks.start_clearance``).

Collision shapes only (no visual shapes: nothing draws this scene), collision detection already run, the client
disconnected when the ``with`` block ends.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

from navstack.jpl import jpl_serpentine


@contextlib.contextmanager
def start_scene(world: Any) -> Iterator[tuple[Any, Any]]:
    """Yield ``(body, scene)``: a :class:`~navstack.sim.body.RobotBody` at ``world.robot.q0`` and the world's
    :class:`~navstack.sim.scene.Scene`, in a fresh DIRECT client."""
    from navstack.sim._bullet import direct_client
    from navstack.sim.body import RobotBody
    from navstack.sim.scene import Scene, SceneOptions

    client = direct_client()
    try:
        body = RobotBody.build(client, jpl_serpentine(), world.robot.base.transform(),
                               serpentine_radius=world.robot.serpentine_radius, arm_radius=world.robot.arm_radius,
                               visuals=False)
        body.reset(world.robot.q0)
        scene = Scene.build(client, world, SceneOptions(visuals=False))
        client.performCollisionDetection()
        yield body, scene
    finally:
        client.disconnect()
