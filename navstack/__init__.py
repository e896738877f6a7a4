"""navstack: sensor-based slithering control of the JPL serpentine robot.

Library entry points (interfaces.md section 5):

* :func:`jpl_serpentine` - the 20-DOF robot model of the paper's Figure 2,
* :func:`load_world` / :class:`WorldError` - world files (``navstack-world/1``),
* :func:`run_trial` - one closed-loop trial, as ``navstack run`` runs it.
"""

from navstack.jpl import jpl_serpentine
from navstack.kinematics import Chain

__all__ = ["Chain", "jpl_serpentine"]
__version__ = "0.1.0"
