"""Robot protective-distance model (paper Sec. III-A, eqs. (1)-(2)).

Pure numpy; no simulator or plotting imports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fftnav.errors import FftnavError
from fftnav.validate import Checked, number_field

__all__ = ["RobotGeometry", "SIM_ROBOT", "REAL_ROBOT", "DRONE"]


@dataclass(frozen=True)
class RobotGeometry(Checked):
    """Lateral collision radius ``r0_m`` and protective radius ``r_m`` of a robot.

    Parameters
    ----------
    r0_m : float
        Lateral collision radius r0 in metres, ``0 < r0_m``.
    r_m : float
        Protective radius r in metres, ``r_m > r0_m``.

    Notes
    -----
    Planning distance, eq. (1): ``l_th = r / cos((pi - alpha) / 2) = r**2 / r0``.
    Safety-sector angle, eq. (2): ``alpha = pi - 2 arccos(r0 / r)``.
    A robot whose safety sector (width alpha, centred on its heading) is free up to
    ``l_th`` cannot collide within ``l_th - r0``.

    Examples
    --------
    >>> g = RobotGeometry(r0_m=0.15, r_m=0.30)
    >>> round(g.l_th_m, 3), round(math.degrees(g.alpha_rad), 1)
    (0.6, 60.0)
    """

    r0_m: float = number_field(low=0, low_open=True)
    r_m: float = number_field(low=0, low_open=True)

    def _check_together(self) -> None:
        r0, r = self.r0_m, self.r_m
        if r <= r0:
            raise FftnavError(f"r_m must be finite and > r0_m={r0!r}, got r_m={r!r}")
        if not math.isfinite(r / r0 * r):  # l_th = r^2 / r0 must be a number too
            raise FftnavError(f"r_m must keep l_th = r_m^2 / r0_m finite, got r_m={r!r} with "
                              f"r0_m={r0!r}")

    @property
    def l_th_m(self) -> float:
        """Planning distance l_th = r**2 / r0 in metres (eq. (1))."""
        return self.r_m**2 / self.r0_m

    @property
    def alpha_rad(self) -> float:
        """Safety-sector angle alpha = pi - 2 arccos(r0 / r) in radians (eq. (2))."""
        return math.pi - 2.0 * math.acos(self.r0_m / self.r_m)

    @property
    def alpha_deg(self) -> float:
        """Safety-sector angle in degrees."""
        return math.degrees(self.alpha_rad)


#: The paper's simulated swarm robot (Sec. IV-B): l_th = 0.6 m, alpha = 60 deg.
SIM_ROBOT = RobotGeometry(r0_m=0.15, r_m=0.30)
#: The paper's real wheeled robot with an Ouster OS0 (Sec. IV-A): l_th = 1.69 m, alpha = 49 deg.
REAL_ROBOT = RobotGeometry(r0_m=0.29, r_m=0.70)
#: The paper's quadrotor with a depth camera (Sec. IV-A): l_th = 2.82 m, alpha = 26.7 deg.
DRONE = RobotGeometry(r0_m=0.15, r_m=0.65)
