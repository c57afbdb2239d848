"""Test helpers shared by the planner's, the message kinds' and the recordings' tests."""

from __future__ import annotations

import math

import numpy as np

from fftnav.world import Polygon, World


def headon(width_m: float) -> World:
    """A 6 m corridor ``width_m`` wide, open at both ends and longer than R (collab's gate opens
    in it); one robot starts at each end, its goal 2 m beyond the other end (as in
    experiments/headon.py)."""
    half = width_m / 2.0

    def box(x0, y0, x1, y1):
        return Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), 1.0)

    return World("headon", 0, (12.0, 8.0),
                 (box(3.0, 4.0 + half, 9.0, 4.2 + half), box(3.0, 3.8 - half, 9.0, 4.0 - half)),
                 np.array([[3.5, 4.0, 0.0], [8.5, 4.0, math.pi]]),
                 np.array([[11.0, 4.0], [1.0, 4.0]]))


def keep_planners(monkeypatch) -> list:
    """A list that receives the Bug planner of every BugController made from now on (the
    oracle of a test that reads the planner's own state after an episode)."""
    from fftnav.navigation import bugcontrol

    planners = []
    init = bugcontrol.BugController.__init__

    def keep(self, *args, **kwargs):
        init(self, *args, **kwargs)
        planners.append(self.planner)

    monkeypatch.setattr(bugcontrol.BugController, "__init__", keep)
    return planners
