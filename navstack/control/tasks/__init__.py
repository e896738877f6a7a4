"""The tasks of equation (4), one per module: each fills its rows of J, z, z_d, zdot_d, W and K.

* :class:`TipTask` (:mod:`.tip`): the tip follows the desired tip,
* :class:`SlitherTask` (:mod:`.slither`): joint points on the recorded tip path (owns the path memory),
* :class:`PostureTask` (:mod:`.posture`): arm joints near a posture,
* :class:`JointLimitTask` (:mod:`.limits`): joints pushed out of a margin near their limits.

The interface (:class:`Task`), the row layout and the shared kinematics are in :mod:`.base`.
"""

from navstack.control.tasks.base import Kinematics, Task, TaskRows
from navstack.control.tasks.limits import JointLimitTask
from navstack.control.tasks.posture import PostureTask
from navstack.control.tasks.slither import SlitherTask
from navstack.control.tasks.tip import TipTask

__all__ = ["JointLimitTask", "Kinematics", "PostureTask", "SlitherTask", "Task", "TaskRows", "TipTask"]
