"""Navigation metrics (Anderson et al. 2018) as pure functions of trajectories and tables."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
import pytest

from fftnav.metrics import (
    MEASURES,
    MOTIONS,
    arrival_rate,
    arrived,
    average_path_length_m,
    evaluate,
    motions,
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


# --- Why robots failed: classify_failure on constructed trajectories -------------------------

DT = 0.1
TICKS = 1200  # 120 s at 10 Hz: a robot that ran out of time has TICKS + 1 samples
GOAL = (0.0, 50.0)  # far from every constructed trajectory: none of them arrives


def _still(n=TICKS + 1, at=(0.0, 0.0)):
    return np.tile(np.asarray(at, float), (n, 1))


def _circle(radius, speed=0.5, n=TICKS + 1, centre=(0.0, 0.0), end=0.0):
    """Counter-clockwise at ``speed``; at angle ``end`` + the window's arc when it stops."""
    angle = end + (np.arange(n) - (n - 201)) * DT * speed / radius
    return np.c_[centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle)]


def _line(start, end, n=TICKS + 1):
    return np.linspace(start, end, n)


def _classify(trajectory, **kw):
    from fftnav.metrics import classify_failure

    return classify_failure(trajectory, kw.pop("goal", GOAL), **kw)


def test_a_robot_that_arrived_has_no_cause():
    assert _classify(_line((0, 0), (0, 49.8), 1000)) == ""
    # the same path reaching the goal after the time limit is not an arrival: it was slow
    assert _classify(_line((0, 0), (0, 49.8), 1300)) == "slow"


def test_collision_wins_over_every_other_cause():
    assert _classify(_line((0, 0), (0, 49.8), 1000), collided=True) == "collision"
    assert _classify(_still(), collided=True) == "collision"
    assert _classify(_circle(1.0), collided=np.bool_(True)) == "collision"


def test_stuck_standing_or_turning_on_the_spot_with_its_boundary():
    poses = np.c_[_still(), np.arange(TICKS + 1) * 0.3]  # turning: the yaw column is ignored
    assert _classify(poses) == "stuck"
    # shuffling back and forth within still_m (the default 0.3 m, inclusive) is stuck; a little
    # more and the same shuffle is a loop (its path is many times its extent)
    for extent, cause in ((0.3, "stuck"), (0.31, "loop")):
        wiggle = np.c_[np.zeros(TICKS + 1), extent * (np.arange(TICKS + 1) % 2)]
        assert _classify(wiggle) == cause, extent


def test_loop_a_robot_circling_far_from_its_goal():
    from fftnav.metrics import failure_features

    f = failure_features(_circle(1.0), GOAL)
    assert f.extent_m == pytest.approx(2.0, abs=1e-3)  # the circle's diameter
    assert f.path_m == pytest.approx(10.0, rel=1e-3)  # 20 s at 0.5 m/s (chords of the arc)
    assert _classify(_circle(1.0)) == "loop"
    # a circle too big to close within the window is not a loop (an arc of 10 m on a radius of
    # 3 m: 3.33 rad, ratio 10 / 6 < 2.5); starting at the top, it gets farther: a detour
    assert _classify(_circle(3.0, end=math.pi / 2)) == "detour"
    # the same arc ending at the top is slow (it came 3 m closer)
    assert _classify(_circle(3.0, end=math.pi / 2 - 10 / 3)) == "slow"


def test_loop_ratio_boundary_on_a_back_and_forth_path():
    # one full A -> B -> A over the window: path = 2 x extent
    n = 201  # the window: 200 intervals of 0.1 s
    there = np.linspace(0.0, 2.0, 101)
    path = np.r_[np.zeros((TICKS + 1 - n, 2)), np.c_[np.zeros(n), np.r_[there, there[-2::-1]]]]
    assert _classify(path, loop_ratio=2.0) == "loop"  # >= is inclusive
    assert _classify(path, loop_ratio=2.01) == "detour"  # it ends where it began: no progress


def test_slow_still_closing_in_and_its_boundary():
    assert _classify(_line((0, 0), (0, 6.0))) == "slow"  # 1 m per 20 s, 44 m short
    window = 200  # the last 20 s gain exactly progress_m = 1 m ...
    ys = np.r_[np.zeros(TICKS - window), np.linspace(0.0, 1.0, window + 1)]
    assert _classify(np.c_[np.zeros(TICKS + 1), ys]) == "slow"
    ys = np.r_[np.zeros(TICKS - window), np.linspace(0.0, 0.99, window + 1)]
    assert _classify(np.c_[np.zeros(TICKS + 1), ys]) == "detour"  # ... or slightly less


def test_detour_moving_sideways_or_away():
    assert _classify(_line((0, 0), (30, 0))) == "detour"  # along a wall, across the goal line
    assert _classify(_line((0, 10), (0, 0))) == "detour"  # driving away


def _neighbour(trajectory, offset, near_ticks=None):
    """Another robot at ``offset`` from the robot for the last ``near_ticks`` samples (all by
    default), absent (NaN) before."""
    other = (np.asarray(trajectory, float)[:, :2] + offset)[:, None, :]
    if near_ticks is not None:
        other[: len(other) - near_ticks] = np.nan
    return other


def test_jam_next_to_another_robot_for_most_of_the_window():
    still = _still()
    assert _classify(still, others=_neighbour(still, (0.3, 0.0))) == "jam"  # in contact
    assert _classify(still, others=_neighbour(still, (0.0, 0.6))) == "jam"  # a robot width
    assert _classify(still, others=_neighbour(still, (0.0, 0.61))) == "stuck"
    # the window has 201 samples: 101 near is most of it, 100 is not
    assert _classify(still, others=_neighbour(still, (0.3, 0), near_ticks=101)) == "jam"
    assert _classify(still, others=_neighbour(still, (0.3, 0), near_ticks=100)) == "stuck"
    # circling round each other is a jam; closing in beside another robot is slow
    circle = _circle(0.5)
    assert _classify(circle, others=_neighbour(circle, (0.3, 0.0))) == "jam"
    line = _line((0, 0), (0, 6.0))
    assert _classify(line, others=_neighbour(line, (0.3, 0.0))) == "slow"
    # blocked means it ended the window less than progress_m (1 m) from where it began it: a
    # robot driving off with another beside it is not jammed, whatever its goal
    window = 200
    for shift, cause in ((0.99, "jam"), (1.0, "detour")):
        xs = np.r_[np.zeros(TICKS - window), np.linspace(0.0, shift, window + 1)]
        sideways = np.c_[xs, np.zeros(TICKS + 1)]
        assert _classify(sideways, others=_neighbour(sideways, (0.0, 0.3))) == cause, shift
    convoy = _line((0, 10), (0, -30))
    assert _classify(convoy, others=_neighbour(convoy, (0.3, 0.0))) == "detour"


def test_jam_share_and_distance_are_parameters():
    still = _still()
    half = _neighbour(still, (0.3, 0), near_ticks=60)  # 60 of 201 samples
    assert _classify(still, others=half) == "stuck"
    assert _classify(still, others=half, jam_share=0.25) == "jam"
    far = _neighbour(still, (1.0, 0))
    assert _classify(still, others=far, jam_distance_m=1.0) == "jam"


def test_only_the_last_window_counts():
    circling_then_still = np.r_[_circle(1.0, n=1000), _still(201, at=_circle(1.0, n=1000)[-1])]
    assert _classify(circling_then_still) == "stuck"
    assert _classify(circling_then_still, window_s=120.0) == "loop"
    short = _circle(1.0, n=50)  # shorter than the window: all of it is looked at
    from fftnav.metrics import failure_features

    assert failure_features(short, GOAL).window_s == pytest.approx(4.9)


def test_every_robot_that_did_not_arrive_gets_a_registered_cause():
    from fftnav.metrics import FAILURE_CAUSES

    assert tuple(FAILURE_CAUSES) == ("collision", "jam", "stuck", "loop", "slow", "detour")
    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(300):
        steps = rng.normal(0, rng.choice([0.001, 0.02, 0.1]), size=(TICKS, 2))
        steps += rng.normal(0, rng.choice([0.0, 0.05]), size=2)  # a drift
        path = np.r_[[[0.0, 0.0]], np.cumsum(steps, axis=0)]
        others = path[:, None, :] + rng.choice([0.3, 5.0])
        collided = bool(rng.random() < 0.1)
        cause = _classify(path, others=others, goal=(0.0, 20.0), collided=collided)
        home = np.hypot(*(path - (0.0, 20.0)).T).min() <= 0.3 and not collided
        assert cause == "" if home else cause in FAILURE_CAUSES
        seen.add(cause)
    assert seen >= set(FAILURE_CAUSES), seen


def test_failure_thresholds_are_the_defaults_of_classify_failure():
    import inspect

    from fftnav.metrics import classify_failure, failure_thresholds

    defaults = {k: p.default for k, p in inspect.signature(classify_failure).parameters.items()}
    assert {k: defaults[k] for k in failure_thresholds()} == failure_thresholds()
    assert failure_thresholds(r0_m=0.25, v_max_mps=1.0, window_s=10.0) == {
        "window_s": 10.0, "still_m": 0.5, "jam_distance_m": 1.0, "progress_m": 1.0}


def test_failure_counts_are_measures_and_summary_columns():
    from fftnav.metrics import FAILURE_CAUSES
    from fftnav.runner.summary import summarize, summary_columns

    table = {**episode_table(), "failure": ["", "collision", "loop"]}
    got = evaluate(table)
    assert [got[f"failures_{c}"] for c in FAILURE_CAUSES] == [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]
    assert np.isnan(got_old := evaluate(episode_table())["failures_loop"]), got_old
    frame = pd.DataFrame({**table, "env": "forest", "policy": "fusion", "map_seed": 1})
    frame.loc[0, "failure"] = np.nan  # pandas reads an empty field as NaN
    summary = summarize(frame, n_resamples=10)
    assert summary_columns()[-len(FAILURE_CAUSES):] == tuple(f"failures_{c}"
                                                             for c in FAILURE_CAUSES)
    assert summary[["failures_collision", "failures_loop", "failures_stuck"]].values.tolist() \
        == [[1.0, 1.0, 0.0]]


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"window_s": 0}, r"window_s must be a finite number > 0, got window_s=0"),
        ({"still_m": -0.1}, r"still_m must be a finite number > 0, got still_m=-0.1"),
        ({"loop_ratio": 1.0}, r"loop_ratio must be a finite number > 1, got loop_ratio=1.0"),
        ({"progress_m": 0.0}, r"progress_m must be a finite number > 0, got progress_m=0.0"),
        ({"jam_distance_m": np.inf}, r"jam_distance_m must be a finite number > 0"),
        ({"jam_share": 0}, r"jam_share must be a finite number in \(0, 1\], got jam_share=0"),
        ({"jam_share": 1.5}, r"jam_share must be a finite number in \(0, 1\], got jam_share=1.5"),
        ({"dt_s": -1}, r"dt_s must be a finite number > 0, got dt_s=-1"),
        ({"time_limit_s": 0}, r"time_limit_s must be a finite number > 0, got time_limit_s=0"),
        ({"success_radius_m": 0}, r"success_radius_m must be a finite number > 0"),
        ({"collided": 1}, r"collided must be a bool, got collided=1"),
        ({"goal": (0, 1, 2)}, r"goal must be 2 finite coordinates, got goal=\(0, 1, 2\)"),
        ({"goal": (0, np.nan)}, r"goal must be 2 finite coordinates"),
        ({"others": np.zeros((5, 1, 2))},
         r"others must be a \(11, M, 2\) array .* got others.shape=\(5, 1, 2\)"),
        ({"others": np.full((11, 1, 2), np.inf)}, r"others must be .*no inf"),
    ],
)
def test_classify_failure_names_a_bad_parameter(kw, message):
    with pytest.raises(ValueError, match=message):
        _classify(_still(11), **kw)


def test_classify_failure_refuses_a_bad_trajectory():
    with pytest.raises(ValueError, match=r"trajectory must be a \(T, 2\) or \(T, 3\) array"):
        _classify(np.zeros((0, 2)))
    with pytest.raises(ValueError, match=r"trajectory must be finite"):
        _classify(np.full((3, 2), np.nan))


def _motions_by_loop(command, moving, control_hz, turn_s):
    """The oracle of motions(): each robot's ticks walked in order, grouped by hand into runs
    of rotating one way (key +-1) and the rest (key 0)."""
    g, n = moving.shape
    out = np.full((g, n), -1)
    shortest = math.ceil(turn_s * control_hz - 1e-9)
    for r in range(n):
        for rotates, run in itertools.groupby(
                range(g), key=lambda k: np.sign(command[k, r, 1]) if (
                    moving[k, r] and command[k, r, 0] == 0 and command[k, r, 1] != 0) else 0):
            ticks = list(run)
            for k in ticks:
                if not moving[k, r]:
                    continue
                if rotates:
                    out[k, r] = MOTIONS.index("turn" if len(ticks) >= shortest else "correct")
                else:
                    out[k, r] = MOTIONS.index("drive" if command[k, r, 0] != 0 else "stand")
    return out


@pytest.mark.parametrize("turn_s", [0.0, 0.3, 1.0])
def test_motions_match_a_tick_by_tick_walk(turn_s):
    """Random commands of 5 robots (driving, rotating either way in runs of every length,
    standing), random gaps in moving: motions() against grouping each robot's ticks by
    hand."""
    rng = np.random.default_rng(11)
    g, n = 400, 5
    v = np.where(rng.random((g, n)) < 0.4, 0.5, 0.0)
    w = np.where(rng.random((g, n)) < 0.7, rng.choice([-1.5, 0.4, 1.5], (g, n)), 0.0)
    w[(v == 0) & (rng.random((g, n)) < 0.1)] = 0.0
    v[100:130, 1], w[100:130, 1] = 0.0, 1.5  # a long turn
    moving = rng.random((g, n)) < 0.95
    command = np.stack([v, w], axis=-1)
    kinds = motions(command, moving, control_hz=10.0, turn_s=turn_s)
    assert np.array_equal(kinds, _motions_by_loop(command, moving, 10.0, turn_s))
    assert set(np.unique(kinds)) == ({-1, 0, 2, 3} if turn_s == 0 else {-1, 0, 1, 2, 3})
    assert (kinds[100:130, 1][moving[100:130, 1]] == MOTIONS.index("turn")).all()


def test_a_robot_swinging_left_and_right_makes_corrections_not_a_turn():
    """30 ticks alternating w = +1.5 and -1.5 rad/s on the spot (a dithering robot): 30
    one-tick corrections; the same 30 ticks all one way are a turn."""
    w = np.where(np.arange(30) % 2 == 0, 1.5, -1.5)
    command = np.stack([np.zeros(30), w], axis=-1)[:, None, :]
    moving = np.ones((30, 1), dtype=bool)
    assert (motions(command, moving, control_hz=10.0) == MOTIONS.index("correct")).all()
    command[:, 0, 1] = 1.5
    assert (motions(command, moving, control_hz=10.0) == MOTIONS.index("turn")).all()


def test_a_pause_in_moving_splits_a_rotation_run():
    """Ten rotating ticks with the robot not moving at the fifth: two runs of 4 and 5 ticks,
    both corrections at a 1 s turn (10 ticks), and the fifth tick is -1."""
    command = np.tile([0.0, 1.0], (10, 1, 1))
    moving = np.ones((10, 1), dtype=bool)
    moving[4] = False
    kinds = motions(command, moving, control_hz=10.0)
    assert kinds[:, 0].tolist() == [1, 1, 1, 1, -1, 1, 1, 1, 1, 1]
    moving[4] = True
    assert (motions(command, moving, control_hz=10.0) == MOTIONS.index("turn")).all()


def test_motions_name_bad_input():
    command, moving = np.zeros((4, 2, 2)), np.ones((4, 2), dtype=bool)
    with pytest.raises(ValueError, match=r"command must have shape \(G, N, 2\), got shape \(4, 2\)"):
        motions(np.zeros((4, 2)), moving, control_hz=10.0)
    with pytest.raises(ValueError, match=r"moving must have shape \(4, 2\).*got shape \(4, 3\)"):
        motions(command, np.ones((4, 3), dtype=bool), control_hz=10.0)
    with pytest.raises(ValueError, match="control_hz"):
        motions(command, moving, control_hz=0.0)
    with pytest.raises(ValueError, match="turn_s"):
        motions(command, moving, control_hz=10.0, turn_s=-1.0)


def test_motions_of_a_recorded_bug_episode_add_up_to_its_paths_and_times():
    """A recorded 4-robot Bug episode (own-only, a small ruin, 12 s): every moving tick is one
    motion, and the driving ticks at v_max make up each robot's path length (the simulator's
    odometry, not the commands) to within a few centimetres; Bug robots never stand."""
    import io

    from fftnav.config import EpisodeConfig, SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.episode.recording import STATUS, read_recording
    from fftnav.world import generate_world

    world = generate_world("rocky", 1003, robots=4, size_m=(10.0, 10.0), goal_y_m=9.0)
    config = SwarmConfig(episode=EpisodeConfig(time_limit_s=12.0))
    result = run_episode(world, "own-only", seed=1, config=config, record=True)
    rec = read_recording(io.BytesIO(result.recording()))
    moving = rec.status[:-1] == STATUS.index("moving")
    kinds = motions(rec.command[:-1], moving, control_hz=config.episode.control_hz)
    assert ((kinds >= 0) == moving).all()
    drive = (kinds == MOTIONS.index("drive")).sum(axis=0) * config.robot.v_max_mps / 10.0
    np.testing.assert_allclose(drive, [r.path_length_m for r in result.rows], atol=0.05)
    assert (kinds == MOTIONS.index("correct")).any()
    assert not (kinds == MOTIONS.index("stand")).any()
