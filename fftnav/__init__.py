"""fftnav: FFT-filtered swarm navigation (Li et al.), as a library, a PyBullet benchmark and a CLI.

Data flow, one module per stage::

    scan -> filters -> safe directions / compressed message -> fusion
         -> planner -> simulator -> metrics -> runner -> report
"""

from fftnav.geometry import DRONE, REAL_ROBOT, SIM_ROBOT, RobotGeometry

__version__ = "0.1.0"

__all__ = ["RobotGeometry", "SIM_ROBOT", "REAL_ROBOT", "DRONE", "__version__"]
