"""fftnav.metrics.paths: a robot's path measures (Anderson et al. 2018) and its motions, as pure
functions of trajectories and commands, against independent oracles."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from fftnav.metrics import (
    MOTIONS,
    arrival_rate,
    arrived,
    average_path_length_m,
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
    ],
)
def test_invalid_inputs_raise(call, message):
    with pytest.raises(ValueError, match=message):
        call()


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
    from fftnav.episode.recording import read_recording
    from fftnav.states import Status
    from fftnav.world import generate_world

    world = generate_world("rocky", 1003, robots=4, size_m=(10.0, 10.0), goal_y_m=9.0)
    config = SwarmConfig(episode=EpisodeConfig(time_limit_s=12.0))
    result = run_episode(world, "own-only", seed=1, config=config, record=True)
    rec = read_recording(io.BytesIO(result.recording()))
    moving = rec.status[:-1] == Status.MOVING
    kinds = motions(rec.command[:-1], moving, control_hz=config.episode.control_hz)
    assert ((kinds >= 0) == moving).all()
    drive = (kinds == MOTIONS.index("drive")).sum(axis=0) * config.robot.v_max_mps / 10.0
    np.testing.assert_allclose(drive, [r.path_length_m for r in result.rows], atol=0.05)
    assert (kinds == MOTIONS.index("correct")).any()
    assert not (kinds == MOTIONS.index("stand")).any()
