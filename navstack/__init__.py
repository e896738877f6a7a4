"""navstack: sensor-based slithering control of the JPL serpentine robot.

Library entry points (interfaces.md section 5):

* :func:`jpl_serpentine` - the 20-DOF robot model of the paper's Figure 2,
* :func:`load_world` / :class:`WorldError` - world files (``navstack-world/1``),
* :func:`run_trial` - one closed-loop trial, as ``navstack run`` runs it.
"""

from navstack.jpl import jpl_serpentine
from navstack.kinematics import Chain
from navstack.trial import TrialResult, run_trial
from navstack.world import World, WorldError, load_world

__all__ = ["Chain", "TrialResult", "World", "WorldError", "jpl_serpentine", "load_world", "run_trial"]
__version__ = "0.1.0"
