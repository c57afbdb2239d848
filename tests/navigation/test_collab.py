"""collab: wall-segment messages (<= 64 bytes), segments fitted to scans, the side of the
shorter way through a map with shared walls, determinism in episodes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from fftnav.config import PAPER_MOTION, EpisodeConfig, SwarmConfig
from fftnav.episode import episode_csv, run_episode
from fftnav.navigation.collab import (
    MAX_MESSAGE_BYTES,
    MAX_SEGMENTS_PER_MESSAGE,
    decode_message,
    encode_message,
    scan_segments,
    waits_for,
)
from fftnav.navigation.ownmap import OwnMaps
from fftnav.world import Polygon, World
from tests.navigation.corridor import headon, keep_planners

UP = math.pi / 2
R = 3.0
ANGLES = -math.pi + np.arange(360) * 2 * math.pi / 360


def test_messages_round_trip_to_the_centimetre_and_stay_within_64_bytes():
    rng = np.random.default_rng(0)
    for n in range(MAX_SEGMENTS_PER_MESSAGE + 1):
        seg = rng.uniform(-300, 300, (n, 2, 2))
        goal = float(rng.uniform(0, 600))
        data = encode_message(seg, goal_m=goal)
        assert len(data) == 3 + 8 * n <= MAX_MESSAGE_BYTES
        goal_back, seg_back = decode_message(data)
        np.testing.assert_allclose(seg_back, seg, atol=0.005 + 1e-9)
        assert goal_back == pytest.approx(goal, abs=0.005 + 1e-9)
    for far in (1e4, math.inf):
        assert decode_message(encode_message(np.zeros((0, 2, 2)), goal_m=far))[0] == 655.35
    with pytest.raises(ValueError, match="segments must hold at most 7 segments"):
        encode_message(np.zeros((8, 2, 2)), goal_m=1.0)
    with pytest.raises(ValueError, match=r"segments must lie within \+-327.67 m"):
        encode_message(np.array([[[400.0, 0.0], [0.0, 0.0]]]), goal_m=1.0)
    with pytest.raises(ValueError, match="goal_m must be >= 0, got goal_m=nan"):
        encode_message(np.zeros((0, 2, 2)), goal_m=math.nan)
    with pytest.raises(ValueError, match="data must be a walls message"):
        decode_message(b"\x01\x00\x00")


def _ranges(x, y, yaw, walls=(), discs=()):
    """Exact ranges (R: no return) against segments ((x0, y0), (x1, y1)) and discs (x, y, r)."""
    out = np.full(len(ANGLES), R)
    for k, a in enumerate(ANGLES + yaw):
        d = np.array([math.cos(a), math.sin(a)])
        for p0, p1 in walls:
            p0, e = np.asarray(p0, float), np.asarray(p1, float) - np.asarray(p0, float)
            m = np.array([d, -e]).T
            if abs(np.linalg.det(m)) > 1e-12:
                t, u = np.linalg.solve(m, p0 - np.array([x, y]))
                if t > 0 and 0 <= u <= 1:
                    out[k] = min(out[k], t)
        for cx, cy, r in discs:
            f = np.array([x - cx, y - cy])
            b, c = f @ d, f @ f - r * r
            if b * b - c >= 0 and -b - math.sqrt(b * b - c) > 0:
                out[k] = min(out[k], -b - math.sqrt(b * b - c))
    return out


def test_scan_segments_find_the_wall_and_not_the_trunk():
    """A wall y = 1.5 from x = -1 to 2 and a trunk of radius 0.2 at (-1, -1.5): one segment,
    along the wall's seen part (readings closer than R), none for the trunk."""
    ranges = _ranges(0.0, 0.0, 0.0, walls=[((-1.0, 1.5), (2.0, 1.5))], discs=[(-1.0, -1.5, 0.2)])
    seg = scan_segments(np.zeros(3), ranges, ANGLES, range_m=R)
    assert seg.shape == (1, 2, 2)
    np.testing.assert_allclose(seg[0, :, 1], [1.5, 1.5], atol=0.01)
    assert sorted(seg[0, :, 0]) == pytest.approx([-1.0, 2.0], abs=0.06)


def test_shared_walls_turn_the_shorter_side():
    """A robot at (5, 3) below a wall y = 4 that it sees from x = 2.5 to 7.5: through its own
    map the ways round the two seen ends are equally long; a neighbour's segment saying the
    wall goes on to x = 9.8 on the right makes the left way shorter by more than 2 m."""
    maps = OwnMaps(1, np.array([0.0, 0.0]), np.array([10.0, 10.0]), resolution_m=0.2,
                   range_m=R, clearance_m=0.3)
    pose = np.array([5.0, 3.0, UP])
    wall = [((0.2, 4.0), (9.8, 4.0))]
    maps.update(0, np.array([0]), pose[None], _ranges(*pose, walls=wall)[None], ANGLES)
    goal = np.array([5.0, 8.0])
    left, right = maps.side_costs(0, pose[:2], goal, radius_m=1.0)
    assert abs(left - right) < 0.5
    maps.add_segments(0, 1, np.array([[[7.0, 4.0], [9.8, 4.0]]]))
    left, right = maps.side_costs(0, pose[:2], goal, radius_m=1.0)
    assert right - left > 2.0
    assert math.isfinite(left)


def _barrier_world():
    """A wall across the map with one gap on the right; four robots below it."""
    walls = (Polygon(((0.0, 4.0), (7.0, 4.0), (7.0, 4.3), (0.0, 4.3)), 1.0),
             Polygon(((8.5, 4.0), (10.0, 4.0), (10.0, 4.3), (8.5, 4.3)), 1.0))
    xs = [1.5, 3.5, 5.5, 7.5]
    return World("t", 0, (10.0, 9.0), walls, np.array([[x, 1.0, UP] for x in xs]),
                 np.array([[x, 8.0] for x in xs]), "walls")


def test_collab_episodes_are_deterministic_and_share_walls():
    world = _barrier_world()
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0, departure="staggered",
                                            stagger_s=4.0)).replace({"packet_loss": 0.3})
    a = run_episode(world, "collab", seed=5, config=cfg)
    b = run_episode(world, "collab", seed=5, config=cfg)
    assert episode_csv(a.rows) == episode_csv(b.rows)
    assert all(np.array_equal(x, y) for x, y in zip(a.trajectories, b.trajectories, strict=True))
    assert sum(r.bytes_sent for r in a.rows) > 0
    assert all(r.bytes_sent <= MAX_MESSAGE_BYTES * r.messages_sent for r in a.rows)
    assert sum(r.arrived for r in a.rows) >= 3


def test_unknown_cells_cost_more_only_where_the_robot_has_not_looked():
    """side_costs with unknown_cost: 1 is the plain length; in a map seen everywhere (every
    cell passed by a beam) a higher cost changes nothing; in the real map, whose left way runs
    through cells above the wall nobody saw, it makes that way dearer (the right one is closed
    by the neighbour's segment to the map edge); below 1 it is refused."""
    maps = OwnMaps(1, np.array([0.0, 0.0]), np.array([10.0, 10.0]), resolution_m=0.2,
                   range_m=R, clearance_m=0.3)
    pose = np.array([5.0, 3.0, UP])
    wall = [((0.2, 4.0), (9.8, 4.0))]
    maps.update(0, np.array([0]), pose[None], _ranges(*pose, walls=wall)[None], ANGLES)
    maps.add_segments(0, 1, np.array([[[7.0, 4.0], [9.8, 4.0]]]))
    goal = np.array([5.0, 8.0])
    plain = maps.side_costs(0, pose[:2], goal, radius_m=1.0)
    assert maps.side_costs(0, pose[:2], goal, radius_m=1.0, unknown_cost=1.0) == plain
    dear = maps.side_costs(0, pose[:2], goal, radius_m=1.0, unknown_cost=3.0)
    assert dear[0] > plain[0] + 5.0 and plain[1] == dear[1] == math.inf  # right: no way
    seen = OwnMaps(1, maps.lo, np.array([10.0, 10.0]), resolution_m=0.2, range_m=R,
                   clearance_m=0.3)
    seen.last_hit[:], seen.last_shared[:] = maps.last_hit, maps.last_shared
    seen.last_free[:] = np.where(maps.last_hit[0] >= 0, -1, 0)[None]  # every other cell seen
    assert seen.side_costs(0, pose[:2], goal, radius_m=1.0, unknown_cost=3.0) == pytest.approx(
        seen.side_costs(0, pose[:2], goal, radius_m=1.0))
    with pytest.raises(ValueError, match=r"unknown_cost must be a finite number >= 1, "
                                         r"got unknown_cost=0.5"):
        maps.side_costs(0, pose[:2], goal, radius_m=1.0, unknown_cost=0.5)


def test_collab_reconsider_changes_sides_when_walls_arrive_and_collab_never_does():
    """Four robots meet the barrier together; while they follow it their neighbours' wall
    segments arrive: ``collab-reconsider`` asks again and changes side (at most once per
    follow, so never more often than it decided), ``collab`` keeps its sides."""
    world = _barrier_world()
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=40.0))
    again = run_episode(world, "collab-reconsider", seed=5, config=cfg).rows
    assert [r.policy for r in again] == ["collab-reconsider"] * 4
    assert any(r.sides_reconsidered > 0 for r in again)
    assert all(r.sides_reconsidered <= r.decisions_left + r.decisions_right for r in again)
    once = run_episode(world, "collab", seed=5, config=cfg).rows
    assert all(r.sides_reconsidered == 0 for r in once)


def test_collab_decides_and_moves_as_own_only_where_no_wall_is_longer_than_the_range(
        monkeypatch):
    """Rocky ruins (rocks, no wall longer than R): collab robots share their rocks' sides but
    read none of it, so every trajectory and every row but the policy's name and the messages
    sent equals own-only's. The same episode with the gate held open from the start (robots
    read their neighbours' segments at once) moves differently: the world is one where reading
    them would change decisions."""
    import dataclasses

    from fftnav.navigation import bugcontrol
    from fftnav.world.generate import generate_world

    world = generate_world("rocky", 1003, robots=6, size_m=(10.0, 10.0), goal_y_m=9.0)
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0))
    own = run_episode(world, "own-only", seed=1, config=cfg)
    collab = run_episode(world, "collab", seed=1, config=cfg)

    def same_moves(a, b):
        return all(np.array_equal(x, y) for x, y in zip(a.trajectories, b.trajectories,
                                                         strict=True))

    def without_messages(row):
        return {k: v for k, v in dataclasses.asdict(row).items()
                if k != "policy" and not k.startswith(("bytes_", "messages_"))}

    assert same_moves(own, collab)
    assert [without_messages(r) for r in own.rows] == [without_messages(r) for r in collab.rows]
    assert sum(r.bytes_sent for r in collab.rows) > 0

    setup = bugcontrol.BugController.__init__

    def gate_open(self, *args, **kwargs):
        setup(self, *args, **kwargs)
        self.messages.gate[:] = True

    monkeypatch.setattr(bugcontrol.BugController, "__init__", gate_open)
    assert not same_moves(own, run_episode(world, "collab", seed=1, config=cfg))


def test_long_wall_is_longer_than_the_range():
    from fftnav.navigation.collab import long_wall

    assert not long_wall(np.zeros((0, 2, 2)), range_m=R)
    assert not long_wall(np.array([[[0.0, 0.0], [3.0, 0.0]]]), range_m=R)
    assert long_wall(np.array([[[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [2.2, 3.2]]]), range_m=R)


def test_two_collab_robots_meeting_head_on_in_a_corridor_pass_each_other(monkeypatch):
    """A corridor 1.2 m wide, longer than R (collab's gate opens): the two robots meet in its
    middle and pass each other, as own-only's do, because each one's map knows where the other
    stands (its messages) and does not take it for a wall. With OwnMaps.set_robots switched
    off, each maps the other as a wall across the corridor and both go back and round it."""
    world = headon(1.2)
    own = run_episode(world, "own-only", seed=0).rows
    collab = run_episode(world, "collab", seed=0).rows
    assert all(r.arrived for r in own + collab)
    assert [r.time_s for r in collab] == pytest.approx([r.time_s for r in own], abs=1.0)
    assert max(r.time_s for r in own) < 20.0
    monkeypatch.setattr(OwnMaps, "set_robots", lambda self, robot, xy: None)
    blind = run_episode(world, "collab", seed=0).rows
    assert min(r.time_s for r in blind) > 3 * max(r.time_s for r in own)


@settings(max_examples=300, deadline=None)
@given(xy=st.tuples(st.floats(-5, 5), st.floats(-5, 5)), heading=st.floats(0, 2 * math.pi),
       gap=st.floats(0.3, 1.15), goals=st.tuples(st.integers(0, 200), st.integers(0, 200)),
       robots=st.tuples(st.integers(0, 14), st.integers(0, 14)))
def test_of_two_robots_in_each_others_way_exactly_one_waits(xy, heading, gap, goals, robots):
    """Two robots facing each other (each in the other's way, goals beyond each other) that
    compare the same announced goal distances agree: exactly one goes first, the one nearer
    its goal (the lower index at a tie); a robot with nobody in its way never waits."""
    (goal_a, goal_b), (a, b) = goals, robots
    assume(a != b)
    u = np.array([math.cos(heading), math.sin(heading)])
    pa = np.array(xy)
    pb = pa + gap * u
    ga, gb = goal_a / 10.0, goal_b / 10.0
    wa = waits_for(pa, pb + 5 * u, index=a, goal_m=ga, neighbours=[[*pb, gb, b]])
    wb = waits_for(pb, pa - 5 * u, index=b, goal_m=gb, neighbours=[[*pa, ga, a]])
    assert wa != wb
    assert wa == ((ga, a) < (gb, b))
    # the same neighbour behind the robot, or beyond the radius, is not in its way (a robot
    # announcing -1 m would go before anyone in its way)
    assert not waits_for(pa, pa - 5 * u, index=a, goal_m=-1.0, neighbours=[[*pb, gb, b]])
    assert not waits_for(pa, pa + 9 * u, index=a, goal_m=-1.0,
                         neighbours=[[*(pa + 1.3 * u), gb, b]])


def test_a_robot_waits_only_for_robots_it_goes_before():
    """With two neighbours in its way, a robot waits only if it goes before both."""
    here, goal = np.array([0.0, 0.0]), np.array([5.0, 0.0])
    first, last = [0.8, 0.2, 9.0, 3], [0.6, -0.3, 1.0, 4]
    assert waits_for(here, goal, index=2, goal_m=5.0, neighbours=[first])
    assert not waits_for(here, goal, index=2, goal_m=5.0, neighbours=[first, last])
    assert not waits_for(here, goal, index=2, goal_m=5.0, neighbours=np.zeros((0, 4)))


def test_in_a_corridor_too_narrow_to_pass_the_robot_with_the_right_of_way_goes_straight(
        monkeypatch):
    """A corridor 0.8 m wide, longer than R: two collab robots meet in it, too close to pass.
    Robot 0 has the right of way (its last message, sent a tick after robot 1's, announced the
    shorter goal distance): it waits while robot 1 gives way, and then drives straight through,
    its path within 2 % of the optimum. Every time a robot asks whether it waits, the goal
    distance it holds for the other is the one the other last announced. Without the right of
    way (Walls.waits switched off) robot 0 backs out first and its path is more than 1.5 times
    as long, and robot 1 drives through once robot 0 has gone; with it, robot 1 goes round."""
    from fftnav.navigation.messages import Walls

    world = headon(0.8)
    asked = []
    waits = Walls.waits

    def spy(self, swarm, robot):
        near = self.near(robot, swarm.tick)
        for goal_m, j in near[:, 2:4]:
            assert goal_m == self.announced_m[int(j)]
        asked.append((robot, len(near)))
        return waits(self, swarm, robot)

    monkeypatch.setattr(Walls, "waits", spy)
    rows = run_episode(world, "collab", seed=0).rows
    assert {robot for robot, n in asked if n} == {0, 1}
    monkeypatch.setattr(Walls, "waits", waits)
    assert run_episode(world, "collab", seed=0).rows == rows
    assert all(r.arrived for r in rows)
    assert rows[0].path_length_m < 1.02 * rows[0].optimal_length_m
    monkeypatch.setattr(Walls, "waits", lambda self, swarm, robot: False)
    alone = run_episode(world, "collab", seed=0).rows
    assert all(r.arrived for r in alone)
    assert alone[0].path_length_m > 1.5 * alone[0].optimal_length_m
    assert alone[1].path_length_m < 1.2 * alone[1].optimal_length_m
    assert rows[1].path_length_m > 1.5 * rows[1].optimal_length_m


def test_with_the_gate_closed_a_collab_robot_never_waits(monkeypatch):
    """The right of way is collab's too only once its gate is open: with the gate held shut
    (no wall ever longer than R), the 0.8 m head-on corridor runs exactly as own-only's."""
    import dataclasses

    from fftnav.navigation import messages

    world = headon(0.8)
    monkeypatch.setattr(messages, "long_wall", lambda segments, *, range_m: False)
    collab = run_episode(world, "collab", seed=0)
    own = run_episode(world, "own-only", seed=0)

    def moves(row):
        return {k: v for k, v in dataclasses.asdict(row).items()
                if k != "policy" and not k.startswith(("bytes_", "messages_"))}

    assert [moves(r) for r in collab.rows] == [moves(r) for r in own.rows]
    assert collab.rows[0].path_length_m > 1.5 * collab.rows[0].optimal_length_m


def test_guided_robots_steer_for_the_gap_and_only_collab_is_guided(monkeypatch):
    """Staggered departures under a wall with one gap on the right: once its gate is open, a
    collab robot heading for its goal steers along its map's way (the planner's guide), toward
    the gap its neighbours and its own scans showed, and no collab robot's path is longer than
    own-only's; fusion's and own-only's robots are never guided."""
    planners = keep_planners(monkeypatch)
    world = _barrier_world()
    # built for the paper's motion (straight, or rotation in place beyond 3 degrees); with the
    # default steered motion two collab robots here go the long way (docs/results.md)
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0, departure="staggered",
                                            stagger_s=4.0)).replace(PAPER_MOTION)
    rows = {p: run_episode(world, p, seed=5, config=cfg).rows
            for p in ("own-only", "fusion", "collab")}
    own, fusion, collab = planners
    assert own.guide is None and fusion.guide is not None  # fusion's kind is asked: it says no
    assert not fusion.stats.guided_ticks.any()
    assert collab.stats.guided_ticks.sum() > 0
    assert all(r.arrived for r in rows["collab"] + rows["own-only"])
    # the robots farthest from the gap go there before they meet the wall: shorter paths
    short = [o.path_length_m - c.path_length_m for o, c in zip(rows["own-only"], rows["collab"],
                                                               strict=True)]
    assert min(short) >= 0.0 and short[0] > 0.5 and collab.stats.guided_ticks[0] > 0
