"""Navigation metrics (Anderson et al. 2018) as pure functions of trajectories and tables."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from fftnav.metrics import (
    MEASURES,
    arrival_rate,
    arrived,
    average_path_length_m,
    evaluate,
    path_length_m,
    spl,
    spl_terms,
    time_to_goal_s,
)


def test_path_length_of_a_resampled_straight_line_is_its_chord():
    rng = np.random.default_rng(3)
    t = np.sort(np.r_[0.0, rng.random(50), 1.0])
    a, b = np.array([1.0, -2.0]), np.array([4.0, 2.0])
    line = a + t[:, None] * (b - a)
    assert path_length_m(line) == pytest.approx(5.0)


def test_path_length_of_polygon_and_3d():
    square = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]], dtype=float)
    assert path_length_m(square) == pytest.approx(8.0)
    helix_t = np.linspace(0, 2 * np.pi, 20001)
    helix = np.stack([np.cos(helix_t), np.sin(helix_t), helix_t / (2 * np.pi)], axis=1)
    assert path_length_m(helix) == pytest.approx(math.hypot(2 * np.pi, 1.0), rel=1e-6)
    assert path_length_m([[3.0, 4.0]]) == 0.0


def straight_approach(speed: float, dt: float, n: int) -> np.ndarray:
    """Robot starting at x = -10 m moving along +x at ``speed`` towards the goal at the origin."""
    x = -10.0 + speed * dt * np.arange(n)
    return np.stack([x, np.zeros(n)], axis=1)


def test_time_to_goal_is_first_sample_inside_radius():
    traj = straight_approach(0.5, 0.1, 400)  # reaches x = -0.3 at t = 19.4 s
    assert time_to_goal_s(traj, [0.0, 0.0], dt_s=0.1) == pytest.approx(19.4)
    times = np.cumsum(np.full(400, 0.2)) - 0.2  # same samples, twice the clock
    assert time_to_goal_s(traj, [0.0, 0.0], times_s=times) == pytest.approx(38.8)
    assert time_to_goal_s(traj, [0.0, 0.0], dt_s=0.1, success_radius_m=1.0) == pytest.approx(18.0)
    assert math.isnan(time_to_goal_s(traj[:100], [0.0, 0.0], dt_s=0.1))


def test_arrived_needs_radius_time_limit_and_no_collision():
    traj = straight_approach(0.5, 0.1, 400)
    goal = [0.0, 0.0]
    assert arrived(traj, goal, dt_s=0.1)
    assert arrived(traj, goal, dt_s=0.1, time_limit_s=19.4)  # exactly at the limit counts
    assert not arrived(traj, goal, dt_s=0.1, time_limit_s=19.3)
    assert not arrived(traj, goal, dt_s=0.1, collided=True)
    at_last_tick = np.r_[np.full(1200, 5.0), [0.0]]  # arrives at tick 1200: 1200 * 0.1 > 120.0
    assert arrived(np.stack([at_last_tick, at_last_tick], 1), goal, dt_s=0.1, time_limit_s=120.0)
    assert not arrived(traj, [0.0, 0.31 + 0.0], dt_s=0.1, success_radius_m=0.3)
    assert arrived(traj, [0.0, 0.29], dt_s=0.1, success_radius_m=0.3)


def spl_oracle(s, p, l):
    total = 0.0
    for si, pi, li in zip(s, p, l, strict=True):
        if si:
            total += 1.0 if max(pi, li) == 0 else li / max(pi, li)
    return total / len(s)


def test_spl_matches_the_definition_on_random_robots():
    rng = np.random.default_rng(11)
    for _ in range(50):
        n = int(rng.integers(1, 20))
        s = rng.random(n) < 0.7
        l = rng.uniform(0, 20, n)
        p = l * rng.uniform(0.8, 1.6, n)
        assert spl(s, p, l) == pytest.approx(spl_oracle(s, p, l))


def test_spl_edge_cases():
    assert spl([False, False], [10.0, 12.0], [10.0, 12.0]) == 0.0  # failure scores 0
    assert spl([True], [9.0], [10.0]) == 1.0  # p < l capped at 1
    assert spl([True, True], [20.0, 10.0], [10.0, 10.0]) == pytest.approx(0.75)
    np.testing.assert_array_equal(spl_terms([True, False], [0.0, 0.0], [0.0, 0.0]), [1.0, 0.0])
    assert spl([True], [2.0], [0.0]) == 0.0  # l = 0 but moved: the formula's 0


def test_arrival_rate_and_apl():
    s = np.array([True, False, True, True])
    p = np.array([20.0, 3.0, 22.0, 21.0])
    assert arrival_rate(s) == 0.75
    assert average_path_length_m(s, p) == pytest.approx(21.0)
    assert math.isnan(average_path_length_m([False, False], [1.0, 2.0]))


def episode_table() -> dict:
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


@pytest.mark.parametrize("as_frame", [False, True])
def test_measures_registry_by_name(as_frame):
    table = episode_table()
    if as_frame:
        table = pd.DataFrame(table)
    got = evaluate(table)
    assert set(got) == set(MEASURES)
    assert got["ar"] == pytest.approx(2 / 3)
    assert got["apl_m"] == pytest.approx(19.5)
    assert got["spl"] == pytest.approx((19 / 20 + 1) / 3)
    assert got["spl_geodesic"] == pytest.approx((18 / 20 + 18 / 19) / 3)
    assert got["collision_rate"] == pytest.approx(1 / 3)
    assert got["time_to_goal_s"] == pytest.approx(60.0)
    assert got["bytes_per_robot"] == pytest.approx(100.0)
    assert got["messages_per_robot"] == pytest.approx(4.0)
    assert got["decisions_per_robot"] == pytest.approx(2.0)
    assert got["share_with_neighbours"] == pytest.approx(2 / 6)
    assert got["share_flipped_by_neighbours"] == pytest.approx(1 / 2)
    assert got["robot_contacts_per_robot"] == pytest.approx(1.0)
    assert got["share_neighbours_fused"] == pytest.approx(3 / 12)  # 12 neighbours counted
    assert got["share_neighbours_no_message"] == pytest.approx(4 / 12)
    assert got["share_neighbours_behind"] == 0.0
    old = {k: v for k, v in episode_table().items() if not k.startswith("neighbours_")}
    assert np.isnan(evaluate(old, ["share_neighbours_lost"])["share_neighbours_lost"])
    assert MEASURES["spl"](table) == got["spl"]
    for name in ("ar", "apl_m", "spl"):  # the interval terms are the measure as a ratio
        num, den = MEASURES[name].terms(table)
        assert num.sum() / den.sum() == pytest.approx(got[name])
    assert MEASURES["apl_m"].columns == ("apl_m", "apl_ci_low", "apl_ci_high")
    assert MEASURES["spl_geodesic"].columns == ("spl_geodesic",)


def test_a_registered_measure_becomes_a_summary_column(monkeypatch):
    from fftnav.metrics import register_measure
    from fftnav.runner.summary import summarize, summary_columns

    monkeypatch.setattr("fftnav.metrics.MEASURES", MEASURES.copy())
    monkeypatch.setattr("fftnav.runner.summary.MEASURES", __import__("fftnav").metrics.MEASURES)
    register_measure("longest_path_m")(lambda t: float(np.max(t["path_length_m"])))
    assert summary_columns()[-1] == "longest_path_m"
    frame = pd.DataFrame({**episode_table(), "env": "forest", "policy": "fusion", "map_seed": 1})
    assert summarize(frame, n_resamples=10)["longest_path_m"].tolist() == [20.0]
    with pytest.raises(ValueError, match="measure 'spl' is already registered"):
        register_measure("spl")(lambda t: 0.0)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: path_length_m(np.zeros((4, 4))), r"trajectory must be a \(T, 2\) or \(T, 3\) array"),
        (lambda: path_length_m([[0.0, np.nan]]), r"trajectory must be finite"),
        (lambda: time_to_goal_s([[0, 0]], [0, 0]), r"give exactly one of dt_s and times_s"),
        (lambda: time_to_goal_s([[0, 0]], [0, 0, 0], dt_s=1), r"goal must be 2 finite coordinates"),
        (lambda: time_to_goal_s([[0, 0]], [0, 0], dt_s=0), r"dt_s must be a finite number > 0, got dt_s=0"),
        (
            lambda: time_to_goal_s([[0, 0], [1, 1]], [0, 0], times_s=[1.0, 0.0]),
            r"times_s must be 2 finite non-decreasing times",
        ),
        (
            lambda: time_to_goal_s([[0, 0]], [0, 0], dt_s=1, success_radius_m=-1),
            r"success_radius_m must be a finite number > 0, got success_radius_m=-1",
        ),
        (
            lambda: arrived([[0, 0]], [0, 0], dt_s=1, time_limit_s=0),
            r"time_limit_s must be a finite number > 0, got time_limit_s=0",
        ),
        (lambda: spl([], [], []), r"success must be a non-empty 1-D array of booleans"),
        (lambda: spl([True], [-1.0], [1.0]), r"path_length_m must be 1 finite lengths >= 0"),
        (lambda: spl([True], [1.0], [np.nan]), r"optimal_length_m must be 1 finite lengths >= 0"),
        (lambda: arrival_rate([2, 0]), r"success must be a non-empty 1-D array of booleans"),
        (lambda: evaluate(episode_table(), ["nope"]),
         r"names must be a registered measure \('ar', .*got names='nope'"),
        (lambda: MEASURES["spl"]({"arrived": [True]}), r"table must have a column 'path_length_m'"),
    ],
)
def test_invalid_inputs_raise(call, message):
    with pytest.raises(ValueError, match=message):
        call()
