"""fftnav.metrics.failures: why a robot did not arrive, on constructed trajectories at each
cause's thresholds; the thresholds dataclass; the declared order of the causes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from fftnav.metrics import (
    FAILURE_CAUSES,
    FailureThresholds,
    classify_failure,
    evaluate,
    failure_features,
    register_failure_cause,
)
from tests.metrics.tables import episode_table

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


def _classify(trajectory, goal=GOAL, **kw):
    """The cause of ``trajectory``: keywords naming a field of FailureThresholds set that
    threshold, the others go to failure_features."""
    limits = {k: kw.pop(k) for k in FailureThresholds.keys() if k in kw}
    kw.setdefault("thresholds", FailureThresholds(**limits))
    return classify_failure(failure_features(trajectory, goal, **kw))


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
    assert failure_features(short, GOAL).window_s == pytest.approx(4.9)


def test_every_robot_that_did_not_arrive_gets_a_registered_cause():
    assert tuple(FAILURE_CAUSES) == ("collision", "lost", "jam", "stuck", "loop", "slow",
                                     "detour")
    assert FAILURE_CAUSES.catch_all() == "detour"
    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(300):
        steps = rng.normal(0, rng.choice([0.001, 0.02, 0.1]), size=(TICKS, 2))
        steps += rng.normal(0, rng.choice([0.0, 0.05]), size=2)  # a drift
        path = np.r_[[[0.0, 0.0]], np.cumsum(steps, axis=0)]
        others = path[:, None, :] + rng.choice([0.3, 5.0])
        collided = bool(rng.random() < 0.1)
        lost = bool(rng.random() < 0.1)
        cause = classify_failure(dataclasses.replace(failure_features(
            path, (0.0, 20.0), others=others, collided=collided), lost=lost))
        home = np.hypot(*(path - (0.0, 20.0)).T).min() <= 0.3 and not collided
        assert cause == "" if home else cause in FAILURE_CAUSES
        assert home or cause == ("collision" if collided else "lost" if lost else cause)
        seen.add(cause)
    assert seen >= set(FAILURE_CAUSES), seen


def test_thresholds_for_a_robot_and_the_defaults_are_the_papers_robot():
    from fftnav.config import SwarmConfig

    robot = SwarmConfig().robot
    paper = FailureThresholds.for_robot(r0_m=robot.r0_m, v_max_mps=robot.v_max_mps)
    assert paper == FailureThresholds.for_robot() == FailureThresholds()
    assert failure_features(_still(), GOAL).thresholds == FailureThresholds()
    # still_m = 2 r0, jam_distance_m = 4 r0, progress_m = a tenth of v_max x window
    assert FailureThresholds.for_robot(r0_m=0.25, v_max_mps=1.0, window_s=10.0) == \
        FailureThresholds(window_s=10.0, still_m=0.5, jam_distance_m=1.0, progress_m=1.0)
    assert FailureThresholds.for_robot(r0_m=0.2, v_max_mps=0.3, window_s=30.0).progress_m == 0.9
    thresholds = FailureThresholds(loop_ratio=3)
    assert thresholds.loop_ratio == 3.0 and isinstance(thresholds.loop_ratio, float)
    with pytest.raises(AttributeError):
        thresholds.loop_ratio = 2.0  # frozen
    with pytest.raises(ValueError, match=r"r0_m must be a finite number > 0, got r0_m=0"):
        FailureThresholds.for_robot(r0_m=0)
    with pytest.raises(ValueError, match=r"v_max_mps must be a finite number > 0"):
        FailureThresholds.for_robot(v_max_mps=-0.5)


def test_the_window_and_the_jam_distance_shape_the_features():
    still = _still()
    beside = _neighbour(still, (0.8, 0.0), near_ticks=50)
    f = failure_features(still, GOAL, others=beside, thresholds=FailureThresholds(window_s=5.0))
    assert f.window_s == pytest.approx(5.0) and f.near_share == 0.0  # 0.8 m: not near
    f = failure_features(still, GOAL, others=beside,
                         thresholds=FailureThresholds(window_s=5.0, jam_distance_m=0.8))
    assert f.near_share == pytest.approx(50 / 51)  # the window's 51 samples, 50 beside it


def test_failure_counts_are_measures_and_summary_columns():
    from fftnav.runner.summary import summarize, summary_columns

    table = {**episode_table(), "failure": ["", "collision", "loop"]}
    got = evaluate(table)
    assert [got[f"failures_{c}"] for c in FAILURE_CAUSES] == [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]
    assert np.isnan(got_old := evaluate(episode_table())["failures_loop"]), got_old
    frame = pd.DataFrame({**table, "env": "forest", "policy": "fusion", "map_seed": 1})
    frame.loc[0, "failure"] = np.nan  # pandas reads an empty field as NaN
    summary = summarize(frame, n_resamples=10)
    always = [c for c, cause in FAILURE_CAUSES.items() if not cause.requires]
    assert always == ["collision", "jam", "stuck", "loop", "slow", "detour"]
    assert summary_columns()[-len(always):] == tuple(f"failures_{c}" for c in always)
    assert summary[["failures_collision", "failures_loop", "failures_stuck"]].values.tolist() \
        == [[1.0, 1.0, 0.0]]
    # an experiment whose robots know only their odometry also counts the lost ones
    odometry = summarize(frame, n_resamples=10, conditions={"odometry"})
    assert summary_columns({"odometry"})[-len(FAILURE_CAUSES):] == tuple(
        f"failures_{c}" for c in FAILURE_CAUSES)
    assert list(odometry.columns) == list(summary_columns({"odometry"}))
    assert "failures_lost" not in summary and odometry["failures_lost"].tolist() == [0.0]


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
        ({"thresholds": {"still_m": 0.3}},
         r"thresholds must be a FailureThresholds, got thresholds=\{'still_m': 0.3\}"),
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
    with pytest.raises(ValueError, match=r"features must be a FailureFeatures"):
        classify_failure(_still(11))


# --- The declared order of the causes ---------------------------------------------------------

BUILT_IN = ("collision", "lost", "jam", "stuck", "loop", "slow", "detour")


@pytest.fixture
def registries(monkeypatch):
    """Copies of FAILURE_CAUSES and MEASURES into which a test registers, so that the package's
    stay as they are."""
    from fftnav.metrics import failures, measures

    monkeypatch.setattr(failures, "FAILURE_CAUSES", failures.FAILURE_CAUSES.copy())
    monkeypatch.setattr(measures, "MEASURES", measures.MEASURES.copy())
    return failures.FAILURE_CAUSES, measures.MEASURES


def _away(f, t):
    return f.progress_m <= -t.progress_m


def _random_walks(n, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        steps = rng.normal(0, rng.choice([0.001, 0.02, 0.1]), size=(TICKS, 2))
        steps += rng.normal(0, rng.choice([0.0, 0.05]), size=2)
        yield np.r_[[[0.0, 0.0]], np.cumsum(steps, axis=0)]


def test_a_cause_registered_before_the_catch_all_takes_its_robots(registries):
    causes, measures = registries
    walks = list(_random_walks(200))
    before = [_classify(w) for w in walks]
    register_failure_cause("away", "it ended the window at least progress_m farther from its "
                           "goal", thresholds=("progress_m",), before="detour")(_away)
    assert tuple(causes) == ("collision", "lost", "jam", "stuck", "loop", "slow", "away",
                            "detour")
    assert causes.catch_all() == "detour" and list(measures)[-1] == "failures_away"
    # it takes exactly the detours whose robot got progress_m (1 m) farther; the rest stay
    after = [_classify(w) for w in walks]
    away = [f.progress_m <= -1.0 for f in (failure_features(w, GOAL) for w in walks)]
    assert after == [("away" if b == "detour" and a else b) for b, a in zip(before, away, strict=True)]
    assert "away" in after and "detour" in after
    assert _classify(_line((0, 10), (0, 0))) == "away"  # driving away: 1.67 m farther
    assert _classify(_line((-3, 0), (3, 0))) == "detour"  # 1 m sideways in the window
    assert _classify(_line((0, 0), (0, 6.0))) == "slow"
    assert _classify(_circle(1.0)) == "loop"
    assert evaluate({"failure": ["away", "", "detour", "away"]}, ["failures_away"]) == {
        "failures_away": 2.0}
    assert "farther from its goal" in measures["failures_away"].description


def test_a_cause_goes_just_before_the_cause_it_names(registries):
    causes, _ = registries
    register_failure_cause("first", "never given", before="collision")(lambda f, t: False)
    register_failure_cause("late", "never given", before="detour")(lambda f, t: False)
    register_failure_cause("mid", "never given", before="stuck")(lambda f, t: False)
    assert tuple(causes) == ("first", "collision", "lost", "jam", "mid", "stuck", "loop", "slow",
                             "late", "detour")
    assert _classify(_still(), collided=True) == "collision"
    # an always-true cause before stuck takes what stuck, loop, slow and detour had
    register_failure_cause("moved", "always", before="stuck")(lambda f, t: True)
    assert _classify(_still()) == "moved" and _classify(_line((0, 0), (0, 6.0))) == "moved"
    assert _classify(_still(), others=_neighbour(_still(), (0.3, 0.0))) == "jam"


@pytest.mark.parametrize(
    ("name", "kw", "message"),
    [
        ("away", {}, r"^failure cause 'away' would never be tested after the catch-all 'detour' "
                     r"\(every robot the causes before 'detour' leave gets it\); register it with "
                     r"before='detour' or an earlier cause$"),
        ("rest", {"catch_all": True},
         r"^failure cause 'rest' would never be tested after the catch-all 'detour'"),
        ("rest", {"catch_all": True, "before": "slow"},
         r"^failure cause 'rest' is a catch-all and must be tested last, got before='slow'$"),
        ("away", {"before": "detuor"},
         r"^before must be one of \[.collision., .lost., .jam., .stuck., .loop., .slow., "
         r".detour.\], "
         r"got before='detuor'$"),
        ("away", {"thresholds": ("progress",), "before": "detour"},
         r"^thresholds of failure cause 'away' must be fields of FailureThresholds "
         r"\('window_s', 'still_m', 'loop_ratio', 'progress_m', 'jam_distance_m', 'jam_share'\), "
         r"got thresholds=\('progress',\)$"),
        ("away", {"thresholds": "progress_m", "before": "detour"},
         r"thresholds of failure cause 'away' must be fields of .*got thresholds='progress_m'$"),
        ("stuck", {"before": "detour"}, r"^failure cause 'stuck' is already registered$"),
    ],
)
def test_a_cause_that_could_never_be_given_is_refused(registries, name, kw, message):
    causes, measures = registries
    names, columns = tuple(causes), tuple(measures)
    with pytest.raises(ValueError, match=message):
        register_failure_cause(name, "a test cause", **kw)(_away)
    assert tuple(causes) == names and tuple(measures) == columns  # nothing registered


def test_the_registry_itself_checks_the_order(registries):
    from fftnav.metrics import FailureCause

    causes, _ = registries
    with pytest.raises(ValueError, match=r"'away' would never be tested after the catch-all"):
        causes.add("away", FailureCause("away", "a test cause", (), _away))
    causes.add("away", FailureCause("away", "a test cause", (), _away), before="slow")
    assert list(causes)[-3:] == ["away", "slow", "detour"]
    assert type(causes.copy()) is type(causes) and tuple(causes.copy()) == tuple(causes)


def test_a_cause_whose_measure_name_is_taken_is_not_registered(registries):
    from fftnav.metrics import register_measure

    causes, _ = registries
    register_measure("failures_away")(lambda t: 0.0)
    with pytest.raises(ValueError, match=r"^measure 'failures_away' is already registered$"):
        register_failure_cause("away", "a test cause", before="detour")(_away)
    assert tuple(causes) == BUILT_IN
