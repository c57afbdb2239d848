"""fftnav: FFT-filtered swarm navigation (Li et al.), as a library, a PyBullet benchmark and a CLI.

Data flow, one module per stage::

    scan -> filters -> safe directions / compressed message -> fusion
         -> planner -> simulator -> metrics -> runner -> report

Every error the library raises on purpose is a :class:`FftnavError` (a ``ValueError``); a
missing optional extra is a :class:`MissingExtraError` (an ``ImportError``) naming its pip line.
"""

from fftnav.errors import FftnavError, MissingExtraError
from fftnav.moved import install as _install_moved
from fftnav.observe.codec import MessageError, decode_message, decode_sigma, encode_sigma
from fftnav.observe.filters import FilterBank
from fftnav.observe.fusion import decide_turn
from fftnav.observe.geometry import DRONE, REAL_ROBOT, SIM_ROBOT, RobotGeometry
from fftnav.observe.pipeline import Pipeline, PipelineResult
from fftnav.observe.safe import is_safe_direction, nearest_safe_headings

__version__ = "0.2.0"

_install_moved()  # the old import paths of moved modules, with a DeprecationWarning

__all__ = [
    "RobotGeometry", "SIM_ROBOT", "REAL_ROBOT", "DRONE", "__version__",
    "FilterBank", "Pipeline", "PipelineResult", "is_safe_direction", "nearest_safe_headings",
    "encode_sigma", "decode_sigma", "decode_message", "MessageError", "decide_turn",
    "FftnavError", "MissingExtraError",
]
