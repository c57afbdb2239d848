"""Near-Euclidean geodesic lengths: free space at all angles, and around a disc (analytic)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.optimal.astar import UnreachableGoalError
from fftnav.optimal.geodesic import geodesic_lengths
from fftnav.optimal.gridgraph import max_excess


def circle_goals(centre: int, radius: float, n: int) -> np.ndarray:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.rint(centre + radius * np.stack([np.sin(angles), np.cos(angles)], axis=1)).astype(int)


@pytest.mark.parametrize(("connectivity", "bound"), [(8, 0.0824), (16, 0.0275), (32, 0.0131)])
def test_max_excess_matches_known_values(connectivity, bound):
    assert max_excess(connectivity) == pytest.approx(bound, abs=1e-4)


def test_free_space_within_1p3_percent_of_euclidean_at_all_angles():
    occupied = np.zeros((101, 101), dtype=bool)
    goals = circle_goals(50, 48, 720)
    starts = np.tile([50, 50], (len(goals), 1))
    euclid = np.hypot(*(goals - starts).T)
    ratio = geodesic_lengths(occupied, starts, goals) / euclid
    assert ratio.min() >= 1 - 1e-12
    assert ratio.max() <= 1 + max_excess(32) + 1e-12
    assert ratio.max() <= 1.015
    # the 8-connected length (the paper's A*) is measurably worse somewhere
    ratio8 = geodesic_lengths(occupied, starts, goals, connectivity=8) / euclid
    assert ratio8.max() > 1.07


def tangent_arc_tangent(rho: float, d1: float, d2: float, phi: float) -> float:
    """Shortest path between points at distances d1, d2 from a disc's centre, angle phi apart."""
    wrap = phi - math.acos(rho / d1) - math.acos(rho / d2)
    if wrap <= 0:  # the straight segment clears the disc
        return math.sqrt(d1**2 + d2**2 - 2 * d1 * d2 * math.cos(phi))
    return math.sqrt(d1**2 - rho**2) + math.sqrt(d2**2 - rho**2) + rho * wrap


@pytest.mark.parametrize("goal_angle_deg", [0.0, 15.0, 40.0])
def test_around_a_disc_matches_tangent_arc_tangent(goal_angle_deg):
    n, c, rho = 141, 70, 30.0
    rows, cols = np.mgrid[0:n, 0:n]
    occupied = np.hypot(rows - c, cols - c) <= rho
    start = np.array([c, c - 65])  # due west, 65 cells from the centre
    a = math.radians(goal_angle_deg)
    goal = np.rint([c + 60 * math.sin(a), c + 60 * math.cos(a)]).astype(int)
    d2 = math.hypot(*(goal - c))
    phi = math.pi - math.atan2(abs(goal[0] - c), goal[1] - c)
    # The occupied cells' squares cover disc(rho - sqrt(2)/2) and lie inside disc(rho + sqrt(2)/2).
    lower = tangent_arc_tangent(rho - math.sqrt(0.5), 65.0, d2, phi)
    upper = tangent_arc_tangent(rho + math.sqrt(0.5), 65.0, d2, phi) * (1 + max_excess(32))
    (got,) = geodesic_lengths(occupied, [start], [goal])
    assert lower <= got <= upper
    assert got == pytest.approx(tangent_arc_tangent(rho, 65.0, d2, phi), rel=0.01)


def test_unreachable_goal_raises():
    occupied = np.zeros((10, 10), dtype=bool)
    occupied[4, :] = True
    with pytest.raises(UnreachableGoalError, match=r"goal cell \(9, 9\) is unreachable from start cell \(0, 0\)"):
        geodesic_lengths(occupied, [(0, 0)], [(9, 9)])


def test_32_connected_cannot_jump_a_one_cell_wall():
    occupied = np.zeros((10, 10), dtype=bool)
    occupied[:, 5] = True
    occupied[0, 5] = False  # a gap at the top
    (got,) = geodesic_lengths(occupied, [(9, 4)], [(9, 6)])
    # must go up through the gap: at least the two vertical legs
    assert got >= 2 * 9
