"""The compiled corridor test (fftnav.navigation.kernels) equals the numpy one bit for bit (the
oracle: bug.corridor_free with the compiled path switched off), on random and real-looking
scans."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from fftnav.navigation import bug, kernels
from fftnav.observe.scan import beam_angles_rad
from fftnav.world.scenes import trunk_scans

pytestmark = pytest.mark.skipif(not kernels.AVAILABLE, reason="numba is not installed")

READING = st.one_of(st.floats(0.0, 1.0), st.floats(0.0, 4.0),
                    st.sampled_from([0.0, math.nan, -1.0, 0.25, 0.45, 3.0]))


def both(ranges, angles, **kw):
    fast = bug.corridor_free(ranges, angles, **kw)
    available, kernels.AVAILABLE = kernels.AVAILABLE, False
    try:
        slow = bug.corridor_free(ranges, angles, **kw)
    finally:
        kernels.AVAILABLE = available
    return fast, slow


@settings(max_examples=100, deadline=None)
@given(hnp.arrays(np.float64, (3, 72), elements=READING), st.sampled_from([72]),
       st.floats(0.05, 0.5), st.floats(0.05, 1.0), st.booleans())
def test_equals_the_numpy_version(ranges, beams, half_width, lookahead, full):
    angles = beam_angles_rad(beams, 2 * math.pi if full else math.radians(240))
    fast, slow = both(ranges, angles, half_width_m=half_width, lookahead_m=lookahead)
    assert fast.dtype == bool and fast.shape == ranges.shape
    assert np.array_equal(fast, slow)


def test_equals_the_numpy_version_on_trunk_scans():
    """The planner's own setting: 360 beams, the robot's half width and lookahead; points on
    the corridor's edges (scans of a wall at exactly the half width) included."""
    scans = trunk_scans(np.random.default_rng(4), 15)
    scans = np.where(scans >= 3.0, 0.0, scans)  # misses read 0 in the planner's input
    angles = beam_angles_rad(360, 2 * math.pi)
    wall = 0.25 / np.abs(np.sin(angles))  # a wall parallel to the heading, 0.25 m to the side
    edge = np.zeros(360)
    edge[270] = 0.25  # one point exactly abeam at the half width: on the corridor's edge
    scans = np.vstack([scans, np.where(wall < 3.0, wall, 0.0), edge])
    fast, slow = both(scans, angles, half_width_m=0.25, lookahead_m=0.45)
    assert np.array_equal(fast, slow)
    assert not fast.all() and fast.any()  # the test sees both outcomes


def test_angles_of_another_length_are_refused():
    """The compiled loop reads one angle per beam: a shorter array is refused, not read past."""
    with pytest.raises(ValueError, match=r"angles_rad \(M,\), got ranges_m.shape=\(2, 360\), "
                                         r"angles_rad.shape=\(180,\)"):
        kernels.corridor_free_compiled(np.ones((2, 360)), np.zeros(180), half_width_m=0.2,
                                        lookahead_m=0.4, reach_m=0.5)
