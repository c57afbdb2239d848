"""A per-robot table of three robots with every episode column the measures read."""

from __future__ import annotations

import numpy as np


def episode_table() -> dict:
    """Robots 0 and 1 arrived (paths 20 and 19 m), robot 2 collided."""
    return {
        "arrived": np.array([True, True, False]),
        "collided": np.array([False, False, True]),
        "path_length_m": np.array([20.0, 19.0, 5.0]),
        "optimal_length_m": np.array([19.0, 19.0, 18.0]),
        "geodesic_length_m": np.array([18.0, 18.0, 17.0]),
        "time_s": np.array([50.0, 70.0, np.nan]),
        "bytes_sent": np.array([100, 200, 0]),
        "messages_sent": np.array([4, 8, 0]),
        "decisions_left": np.array([1, 2, 0]),
        "decisions_right": np.array([0, 1, 2]),
        "decisions_with_neighbours": np.array([1, 1, 0]),
        "decisions_flipped_by_neighbours": np.array([0, 1, 0]),
        "robot_contacts": np.array([1, 0, 2]),
        "spl": np.array([19 / 20, 1.0, 0.0]),
        "neighbours_fused": np.array([2, 1, 0]),
        "neighbours_out_of_range": np.array([0, 3, 0]),
        "neighbours_too_close": np.array([1, 0, 0]),
        "neighbours_behind": np.array([0, 0, 0]),
        "neighbours_no_message": np.array([4, 0, 0]),
        "neighbours_lost": np.array([0, 1, 0]),
    }
