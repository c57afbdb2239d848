"""Episodes in the PyBullet simulator: planner, policies, messages and metrics together."""

import csv
import math
import subprocess
import sys

import numpy as np
import pytest

from fftnav.config import CommsConfig, EpisodeConfig, SwarmConfig
from fftnav.episode import EPISODE_COLUMNS, episode_csv, run_episode
from fftnav.observe.codec import decode_message
from fftnav.observe.fusion import decide_turn
from fftnav.observe.geometry import SIM_ROBOT
from fftnav.observe.pipeline import Pipeline
from fftnav.world import Circle, Polygon, World, raycast_world

UP = math.pi / 2


def _world(obstacles, starts, goals, size=(8.0, 10.0)):
    return World("test", 0, size, tuple(obstacles), np.array(starts, float), np.array(goals, float))


def _box(x0, x1, y0, y1):
    return Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), 1.0)


def _crossing_x(path, y):
    """x where the trajectory first crosses the line y."""
    k = int(np.argmax(path[:, 1] >= y))
    assert path[k, 1] >= y, "the robot never crossed the line"
    return float(path[k, 0])


CFG = SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0))


def test_single_robot_in_an_empty_world_is_near_optimal():
    world = _world([], [[4, 1, UP]], [[4, 9]])
    res = run_episode(world, "fusion", seed=0, config=CFG)
    row = res.rows[0]
    assert row.arrived and not row.collided
    assert row.optimal_length_m == pytest.approx(8.0, abs=0.06)  # start to goal point
    assert 7.6 < row.path_length_m < 8.0  # it stops within 0.3 m of the goal
    assert row.spl >= 0.97
    assert row.decisions_left + row.decisions_right == 0


def test_the_method_s_compute_is_timed_over_every_robot_tick():
    world = _world([], [[3, 1, UP], [5, 1, UP]], [[3, 9], [5, 9]])
    res = run_episode(world, "fusion", seed=0, config=CFG)
    # a robot is served at each tick it drives: one trajectory sample after its start
    assert res.robot_ticks == sum(len(t) - 1 for t in res.trajectories)
    assert res.compute_s > 0
    assert res.compute_ms == pytest.approx(1000 * res.compute_s / res.robot_ticks)


WALL = _box(2.5, 5.5, 4.5, 4.8)  # 3 m wide, centred on the robot's straight line x = 4


@pytest.mark.parametrize(("policy", "left"), [("bug-left", True), ("bug-right", False)])
def test_baselines_pass_a_wide_wall_on_their_side(policy, left):
    res = run_episode(_world([WALL], [[4, 1, UP]], [[4, 9]]), policy, seed=0, config=CFG)
    row, path = res.rows[0], res.trajectories[0]
    assert row.arrived and not row.collided
    x = _crossing_x(path, 4.65)  # heading +y: left is -x
    assert (x < 2.5) if left else (x > 5.5)
    assert (row.decisions_left, row.decisions_right)[0 if left else 1] >= 1


# The wall reaches the world's left edge region and leaves only the right side open; the
# mirrored scene leaves only the left side open.
ONE_SIDED = [_box(0.2, 4.6, 4.0, 4.3), _box(0.2, 0.5, 1.5, 4.0)]
MIRRORED = [_box(8 - x1, 8 - x0, y0, y1) for (x0, x1, y0, y1) in ((0.2, 4.6, 4.0, 4.3),
                                                                    (0.2, 0.5, 1.5, 4.0))]


@pytest.mark.parametrize("policy", ["own-only", "fusion"])
@pytest.mark.parametrize(("obstacles", "open_right"), [(ONE_SIDED, True), (MIRRORED, False)])
def test_observation_based_policies_choose_the_open_side(policy, obstacles, open_right):
    res = run_episode(_world(obstacles, [[4, 1, UP]], [[4, 9]]), policy, seed=0, config=CFG)
    row, path = res.rows[0], res.trajectories[0]
    assert row.arrived, row
    x = _crossing_x(path, 4.15)
    assert (x > 4.6) if open_right else (x < 3.4)
    first = "decisions_right" if open_right else "decisions_left"
    assert getattr(row, first) >= 1


def test_a_neighbour_seeing_open_space_on_the_left_flips_a_balanced_robot():
    """Robot 0 faces a tree head-on (a symmetric view: P_s = 1/2, undecided on its own).
    Neighbour 1, ahead on its left, sees open space toward the target; its real message bytes
    make the fused P exceed 1/2."""
    pipe = Pipeline(SIM_ROBOT, beams=360, range_m=3.0)
    trees = [Circle((4.0, 3.0), 0.3, 1.0)]
    world = _world(trees, [[4, 2.2, UP], [2.5, 3.5, UP]], [[4, 9], [2.5, 9]])
    angles = pipe.angles_rad[None, :] + world.starts[:, 2:3]
    scans = raycast_world(world, world.starts[:, :2], angles, 3.0)
    scans[:, np.abs(pipe.angles_rad) > math.pi - math.radians(7.5)] = 0.0  # blind sector
    res = pipe.process(scans)
    own = res.sigma[0]
    alone = decide_turn(own, neighbours=[], rel_poses=np.zeros((0, 3)), target_rad=0.0,
                        geometry=SIM_ROBOT, range_m=3.0, max_range_m=6.0)
    assert alone.p == alone.p_s == pytest.approx(0.5, abs=1e-9)
    sig, is_min = decode_message(res.messages[1], range_m=3.0)
    rel = world.starts[1] - world.starts[0]  # both face +y: rotate world -> robot frame
    rel_pose = np.array([[rel[1], -rel[0], 0.0]])
    fused = decide_turn(own, neighbours=[(sig, is_min)], rel_poses=rel_pose, target_rad=0.0,
                        geometry=SIM_ROBOT, range_m=3.0, max_range_m=6.0)
    assert fused.sides.tolist() == [1] and fused.p_neighbours[0] > 0.5
    assert fused.turn_left and fused.p > 0.51


def test_same_seed_same_rows_and_trajectories():
    world = _world([WALL, Circle((2.0, 7.0), 0.3, 1.0)], [[3, 1, UP], [5, 1, UP]], [[3, 9], [5, 9]])
    a = run_episode(world, "random", seed=4, config=CFG)
    b = run_episode(world, "random", seed=4, config=CFG)
    assert episode_csv(a.rows) == episode_csv(b.rows)
    for ta, tb in zip(a.trajectories, b.trajectories, strict=True):
        np.testing.assert_array_equal(ta, tb)


def test_fusion_robots_send_bytes_and_baselines_send_none():
    world = _world([WALL], [[3.5, 2.0, UP], [4.5, 1.0, UP]], [[3.5, 9], [4.5, 9]])  # 0 ahead of 1
    fusion = run_episode(world, "fusion", seed=0, config=CFG)
    left = run_episode(world, "bug-left", seed=0, config=CFG)
    assert sum(r.bytes_sent for r in fusion.rows) > 0
    assert all(r.messages_sent * 4 <= r.bytes_sent for r in fusion.rows)
    assert all(r.bytes_sent == 0 for r in left.rows)
    for r in fusion.rows:
        decisions = r.decisions_left + r.decisions_right
        assert r.decisions_flipped_by_neighbours <= r.decisions_with_neighbours <= decisions
    assert sum(r.decisions_with_neighbours for r in fusion.rows) >= 1
    assert all(r.decisions_with_neighbours == 0 for r in left.rows)


def test_bad_episode_parameters_are_named():
    with pytest.raises(ValueError, match=r"packet_loss must be a finite number in \[0, 1\), got "
                       r"packet_loss=1.5"):
        CommsConfig(packet_loss=1.5)
    with pytest.raises(ValueError, match=r"must be a registered policy or controller .*, got "
                                         r"policy='bug-up'$"):
        run_episode(_world([], [[4, 1, UP]], [[4, 9]]), "bug-up", seed=0)
    with pytest.raises(ValueError, match=r"seed must be an integer >= 0, got seed=-1"):
        run_episode(_world([], [[4, 1, UP]], [[4, 9]]), "bug-left", seed=-1)


def _fftnav(*args, cwd):
    return subprocess.run([sys.executable, "-m", "fftnav", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=600)


def test_cli_full_15_robot_forest_episode_writes_a_well_formed_csv(tmp_path):
    gen = _fftnav("world", "generate", "--env", "forest", "--seed", "3", "--out", "w.json",
                  cwd=tmp_path)
    assert gen.returncode == 0, gen.stderr
    run = _fftnav("episode", "--world", "w.json", "--policy", "fusion", "--seed", "1", "--out",
                  "e.csv", "--trajectories", "t.npz", "--plot", "p.png", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    with open(tmp_path / "e.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == EPISODE_COLUMNS
    assert [int(r["robot"]) for r in rows] == list(range(15))
    assert {r["arrived"] for r in rows} <= {"true", "false"}
    assert {r["policy"] for r in rows} == {"fusion"}
    for r in rows:
        p, l = float(r["path_length_m"]), float(r["optimal_length_m"])
        assert l > 17.0 and p > 0
        spl = float(r["spl"])
        assert spl == (pytest.approx(l / max(p, l), abs=1e-5) if r["arrived"] == "true" else 0.0)
    assert sum(r["arrived"] == "true" for r in rows) >= 12
    with np.load(tmp_path / "t.npz") as npz:
        assert len(npz.files) == 15 and npz["arr_0"].shape[1] == 3
    assert (tmp_path / "p.png").stat().st_size > 10_000


@pytest.mark.parametrize(("pair", "message"), [
    ("beams=abc", "sensor.beams must be an integer, got sensor.beams='abc'"),
    ("sensor.range_m=-1", "sensor.range_m must be a finite number in (0, 1000], got sensor.range_m=-1.0"),
    ("colour=red", "unknown key 'colour'; expected one of ['robot.r0_m', "),
    ("packet_loss", "--set expects KEY=VALUE"),
])
def test_cli_bad_set_is_refused_before_the_world_is_read(tmp_path, pair, message):
    run = _fftnav("episode", "--world", "missing.json", "--policy", "fusion", "--set", pair,
                  cwd=tmp_path)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.count("\n") == 1 and message in run.stderr


def test_cli_set_overrides_the_swarm_config(tmp_path):
    from fftnav.world import save_world

    save_world(_world([], [[4, 1, UP]], [[4, 9]]), tmp_path / "w.json")
    run = _fftnav("episode", "--world", "w.json", "--policy", "bug-left", "--set",
                  "episode.time_limit_s=3", "--set", "v_max_mps=0.2", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    row = list(csv.DictReader(run.stdout.splitlines()))[0]
    assert row["arrived"] == "false" and 0.5 < float(row["path_length_m"]) <= 0.6 + 1e-6


def test_cli_bad_policy_exits_2_with_one_line(tmp_path):
    _fftnav("world", "generate", "--env", "forest", "--seed", "3", "--out", "w.json", cwd=tmp_path)
    run = _fftnav("episode", "--world", "w.json", "--policy", "nope", cwd=tmp_path)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.count("\n") == 1 and "got policy='nope'" in run.stderr
    assert "must be a registered policy or controller ('bug-left'" in run.stderr


def test_cli_misspelled_policy_gets_a_suggestion(tmp_path):
    _fftnav("world", "generate", "--env", "forest", "--seed", "3", "--out", "w.json", cwd=tmp_path)
    run = _fftnav("episode", "--world", "w.json", "--policy", "fusoin", cwd=tmp_path)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.count("\n") == 1
    assert run.stderr.rstrip().endswith("got policy='fusoin'; did you mean 'fusion'?")


@pytest.mark.parametrize("turn", [0.0, 0.7, 2.0, -2.9])
def test_decider_fuses_in_the_goal_frame_whatever_the_world_orientation(turn):
    """The episode's decider (own Sigma rotated into the goal frame, neighbour packets decoded
    and placed with the relative pose) gives the same P_s and P when the whole scene is rotated,
    and the same P as decide_turn called by hand in the goal frame."""
    from fftnav.episode.comms import Channel
    from fftnav.navigation.controllers import SwarmStep
    from fftnav.navigation.decider import Decider
    from fftnav.observe.fusion import rotate_sigma

    pipe = Pipeline(SIM_ROBOT, beams=360, range_m=3.0)
    trees = [Circle((4.0, 3.0), 0.3, 1.0), Circle((3.0, 4.6), 0.25, 1.0)]
    world = _world(trees, [[4, 2.2, UP + 0.3], [2.5, 3.5, UP - 0.2]], [[4, 9], [2.5, 9]])
    angles = pipe.angles_rad[None, :] + world.starts[:, 2:3]
    res = pipe.process(raycast_world(world, world.starts[:, :2], angles, 3.0))

    c, s = math.cos(turn), math.sin(turn)
    rot = np.array([[c, -s], [s, c]])
    poses = world.starts.copy()
    poses[:, :2] = poses[:, :2] @ rot.T
    poses[:, 2] += turn
    goal = np.array([4.0, 9.0]) @ rot.T
    channel = Channel(2, range_m=6.0, rng=np.random.default_rng(0))
    channel.broadcast(1, res.messages[1], tick=0, poses=poses, active=np.ones(2, bool))
    channel.deliver(1)
    dec = Decider(CFG, np.random.default_rng(0), full_circle=True)
    dec.observe(SwarmStep(
        tick=1, time_s=0.1, poses=poses, goals=np.array([goal, [2.5, 9.0]]),
        active=np.array([0]), ranges_m=np.zeros((2, 1)), angles_rad=np.zeros(1), safe=None,
        y1=None, messages=None, sigma=[res.sigma[0]],
        inbox=lambda i: channel.inbox(i, tick=1, max_age_ticks=10)))
    p_s, p = dec.own_probability(0), dec.fused_probability(0)

    # by hand, in the unrotated world: goal frame = heading + beta
    beta = math.atan2(9.0 - 2.2, 0.0) - world.starts[0, 2]
    frame = world.starts[0, 2] + beta
    rel = world.starts[1, :2] - world.starts[0, :2]
    cf, sf = math.cos(frame), math.sin(frame)
    rel_pose = [[cf * rel[0] + sf * rel[1], -sf * rel[0] + cf * rel[1],
                 world.starts[1, 2] - frame]]
    sig, is_min = decode_message(res.messages[1], range_m=3.0)
    ref = decide_turn(rotate_sigma(res.sigma[0], -beta), neighbours=[(sig, is_min)],
                      rel_poses=np.array(rel_pose), target_rad=0.0, geometry=SIM_ROBOT,
                      range_m=3.0, max_range_m=6.0)
    assert p_s == pytest.approx(ref.p_s, abs=1e-12)
    assert p == pytest.approx(ref.p, abs=1e-12)
    assert ref.sides.tolist() == [1] and ref.p != ref.p_s  # the neighbour is fused, on the left


class _Hooked:
    """A controller factory whose controllers drive straight at their goals and log every hook
    with the number of ticks they have driven."""

    def __init__(self):
        self.log = []

    def __call__(self, setup):
        from fftnav.navigation.controllers import Controller

        log = self.log

        class Straight(Controller):
            uses_pipeline = False
            ticks = 0

            def step(self, swarm):
                Straight.ticks += 1
                return super().step(swarm)

            def act(self, obs):
                return self.v_max_mps, 2.0 * obs.goal_bearing_rad

            def hold(self, robot):
                log.append(("hold", robot, Straight.ticks))

            def release(self, robot):
                log.append(("release", robot, Straight.ticks))

            def finish(self, robot):
                log.append(("finish", robot, Straight.ticks))

        return Straight(setup)


def test_the_core_departs_arrives_collides_and_times_out_each_robot_once_at_its_tick():
    """Staggered by 1 s: robot 0 arrives 1 m ahead, robot 1 (departs at tick 10) drives into a
    trunk, robot 2 (departs at tick 20) is 12 m from its goal: out of time at 20 + 30 ticks."""
    from fftnav.episode.core import EpisodeCore
    from fftnav.sim.swarm import SimConfig, SwarmSim
    from fftnav.states import Status

    world = _world([Circle((4.0, 2.5), 0.3, 1.0)], [[1, 1, UP], [4, 1, UP], [7, 1, UP]],
                   [[1, 2], [4, 6], [7, 13]], size=(8.0, 14.0))
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=3.0, departure="staggered",
                                            stagger_s=1.0))
    hooked = _Hooked()
    with SwarmSim(world, config=SimConfig.for_swarm(cfg)) as sim:
        core = EpisodeCore(world, cfg, sim, seed=0, controller=hooked)
        with pytest.raises(ValueError, match=r"advance\(\) needs the swarm of tick 0: call "
                                             r"observe\(\) first, got the swarm of tick None"):
            core.advance(np.zeros((3, 2)), {})
        statuses, active = [], []
        while True:
            alive = core.begin_tick()
            statuses.append([Status(int(s)) for s in core.status()])
            if not alive:
                break
            swarm = core.observe()
            active.append(swarm.active.tolist())
            assert swarm.present.tolist() == [s.label in ("waiting", "moving")
                                              for s in statuses[-1]]
            core.advance(*core.controller.step(swarm))
        core.end()
        paths = core.trajectories()
    first = {(i, s): statuses.index(next(row for row in statuses if row[i] == s))
             for i in range(3) for s in Status if any(row[i] == s for row in statuses)}
    # robot 0: arrived at the first tick its pose is within 0.3 m of its goal
    near = np.hypot(*(paths[0][:, :2] - [1.0, 2.0]).T) <= 0.3
    assert near.tolist() == [False] * (len(near) - 1) + [True] and 13 <= len(near) - 1 <= 15
    assert first[0, Status.ARRIVED] == len(near) - 1
    # robot 1: waits 10 ticks, then drives to the trunk (its edge 2.2 m minus r0 = 0.15 m)
    assert first[1, Status.MOVING] == 10 and first[1, Status.COLLIDED] - 10 == len(paths[1]) - 1
    assert paths[1][-1, 1] == pytest.approx(2.05, abs=0.06)
    # robot 2: its 3 s start at its departure, tick 20
    assert first[2, Status.MOVING] == 20 and first[2, Status.TIMED_OUT] == 50
    assert len(paths[2]) == 31 and len(statuses) == 51
    assert active[0] == [0] and active[10] == [0, 1] and active[20] == [1, 2]
    assert sorted(hooked.log) == sorted([
        ("hold", 1, 0), ("hold", 2, 0), ("release", 1, 10), ("release", 2, 20),
        ("finish", 0, first[0, Status.ARRIVED]), ("finish", 1, first[1, Status.COLLIDED]),
        ("finish", 2, 50)])
