"""Configuration control of the paper's equation (4): slithering of the JPL serpentine robot.

Equation (4) (damped least squares / configuration control) is in :mod:`navstack.control.equation4`::

    thetadot_d = [J^T W J + lambda^2 W_v]^-1 J^T W (zdot_d + K e),   e = z_d - z,

integrated to the desired joint trajectory ``theta_d``.  The rest of the package builds its inputs:

* :mod:`navstack.control.tasks`: one module per task (tip, slither, posture, joint limits), each filling
  its rows of J, z_d, zdot_d, e, W and K, with the interface in :mod:`navstack.control.tasks.base`;
* :mod:`navstack.control.damping`: the adaptive lambda;
* :mod:`navstack.control.solver`: stacks the tasks and solves (4);
* :mod:`navstack.control.controller`: :class:`SlitherController`, which integrates ``theta_d``;
* :mod:`navstack.control.config`: :class:`ControlConfig`.
"""

from navstack.control.config import MODES, ControlConfig, SlitherMode
from navstack.control.controller import ControlError, SlitherController
from navstack.control.equation4 import dls_rate
from navstack.control.tasks.base import TaskRows

__all__ = ["MODES", "ControlConfig", "ControlError", "SlitherController", "SlitherMode", "TaskRows", "dls_rate"]
