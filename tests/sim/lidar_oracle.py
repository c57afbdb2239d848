"""Shared oracle of the lidar tests: PyBullet ranges against exact analytic ray casts."""

from __future__ import annotations

import numpy as np

from fftnav.world import World, raycast_world


def assert_ranges_match_analytic(world: World, origins: np.ndarray, angles: np.ndarray,
                                 got: np.ndarray, range_m: float = 3.0) -> np.ndarray:
    """Assert that lidar ranges ``got`` (K, M) equal ``raycast_world`` within 1 cm on every ray
    that does not graze an obstacle; return the analytic ranges.

    Rays grazing a trunk or a corner are ill-conditioned: Bullet's shapes carry a margin of
    about 1 mm, which decides hit or miss there. A ray is grazing when turning it by 0.1 deg
    changes the analytic answer by more than 1 cm (allowed on under 10 % of the rays); on those
    rays Bullet's range must still lie within 1 cm of the analytic envelope over the turns.
    """
    expected = raycast_world(world, origins, angles, range_m)
    turned = [raycast_world(world, origins, angles + d, range_m) for d in np.radians([-0.1, 0.1])]
    graze = np.max(np.abs(np.array(turned) - expected), axis=0) > 0.01
    assert graze.mean() < 0.1
    assert np.abs(got - expected)[~graze].max() < 0.01
    low, high = np.min([expected, *turned], axis=0), np.max([expected, *turned], axis=0)
    assert np.all((got > low - 0.01) & (got < high + 0.01))
    return expected
