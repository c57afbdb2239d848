import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fftnav.config import PlannerConfig
from fftnav.navigation.bug import BugPlanner, PlannerParams, motion_command
from fftnav.navigation.memory import Hit
from fftnav.navigation.policies import LEFT, RIGHT
from fftnav.states import State

M = 360
FOV = 2 * math.pi


def _mask(blocked_deg=()):
    """Safe everywhere except the given (lo, hi) degree intervals and the rear 15 degrees."""
    ang = np.degrees(-math.pi + np.arange(M) * 2 * math.pi / M)
    safe = np.abs(ang) < 172.5
    for lo, hi in blocked_deg:
        safe &= ~((ang >= lo) & (ang <= hi))
    return safe


def _planner(side, n=1, **kw):
    calls = []

    def decide(i):
        calls.append(i)
        return side

    return BugPlanner(n, l_th_m=0.6, r0_m=0.15, fov_rad=FOV, decide=decide, params=PlannerParams(**kw)), calls


def _step(planner, t, pose, goal, safe):
    safe = np.atleast_2d(safe)
    ranges = np.where(safe, 3.0, 0.3)
    return planner.step(t, np.array([pose], float), np.array([goal], float), safe=safe,
                        ranges_m=ranges, y1=ranges.astype(float))


def test_clear_goal_drives_straight_and_misaligned_goal_rotates_toward_it():
    p, calls = _planner(LEFT)
    cmd, blocked = _step(p, 0.0, (0, 0, 0), (10, 0), _mask())
    assert cmd.tolist() == [[0.5, 0.0]] and not blocked[0] and calls == []
    cmd, _ = _step(p, 0.1, (0, 0, 0), (0, 10), _mask())  # goal at +90 deg: rotate left, capped
    assert cmd.tolist() == [[0.0, 1.5]]
    # a small error (5.7 degrees) is turned within one period, while driving by default
    cmd, _ = _step(p, 0.2, (0, 0, 0), (10, -1.0), _mask())
    assert cmd[0, 0] == 0.5 and cmd[0, 1] == pytest.approx(10 * math.atan2(-1.0, 10), abs=1e-9)
    paper, _ = _planner(LEFT, heading_tol_deg=3.0, drive="straight")  # in place beyond 3 degrees
    cmd, _ = _step(paper, 0.0, (0, 0, 0), (10, -1.0), _mask())
    assert cmd[0, 0] == 0.0 and cmd[0, 1] == pytest.approx(10 * math.atan2(-1.0, 10), abs=1e-9)


@pytest.mark.parametrize(("side", "sign"), [(LEFT, 1), (RIGHT, -1)])
def test_blocked_goal_asks_the_policy_once_and_turns_to_that_side(side, sign):
    p, calls = _planner(side)
    cmd, blocked = _step(p, 0.0, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
    assert blocked[0] and calls == [0]
    assert cmd[0, 0] == 0.0 and np.sign(cmd[0, 1]) == sign
    assert p.state(0) is State.FOLLOW and p.stats.decisions[0].tolist() == (
        [1, 0] if side == LEFT else [0, 1]
    )
    # still blocked next tick: keeps the side without a new decision
    _step(p, 0.1, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
    assert calls == [0]


def test_leave_rule_needs_clear_goal_and_progress():
    p, _ = _planner(LEFT)
    _step(p, 0.0, (0, 0, 0), (10, 0), _mask([(-30, 30)]))  # hit at d = 10
    _step(p, 0.1, (0, 0.5, 0), (10, 0), _mask())  # clear but farther: stay in FOLLOW
    assert p.state(0) is State.FOLLOW
    _step(p, 0.2, (1.0, 0.5, 0), (10, 0), _mask())  # clear and closer: leave
    assert p.state(0) is State.GOAL


def test_loop_detection_starts_an_escape_after_the_timeout_once():
    """Blocked forever without progress: after loop_timeout_s the robot escapes (through its
    own map) instead of following; the side is kept and the policy asked once."""
    p, calls = _planner(LEFT, loop_timeout_s=5.0)
    escaped_at = None
    for k in range(200):
        _step(p, 0.1 * k, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
        if escaped_at is None and p.state(0) is State.ESCAPE:
            escaped_at = 0.1 * k
    assert escaped_at == pytest.approx(5.1, abs=0.01)
    assert calls == [0] and p.memory[0].side == LEFT and p.stats.loop_flips[0] == 1
    assert p.stats.escape_ticks[0] > 0


def test_an_escape_ends_by_the_leave_rule_and_the_robot_heads_for_its_goal():
    """FOLLOW, then ESCAPE after the loop timeout, each with its side; once the goal direction
    is clear and the robot got closer than at the hit point, GOAL with no side (the follow's
    side is kept for the record), and a new blocked goal direction is a new decision (FOLLOW,
    the escape over)."""
    p, calls = _planner(LEFT, loop_timeout_s=5.0)
    _step(p, 0.0, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
    assert p.state(0) is State.FOLLOW and p.memory[0].side == LEFT
    for k in range(1, 60):
        _step(p, 0.1 * k, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
    assert p.state(0) is State.ESCAPE and p.memory[0].side == LEFT
    _step(p, 6.0, (1.0, 0.5, 0), (10, 0), _mask())  # clear and 0.9 m closer: the leave rule
    assert p.state(0) is State.GOAL and p.memory[0].side == 0
    assert p.memory[0].follow.side == LEFT and calls == [0]
    _step(p, 6.1, (1.0, 0.5, 0), (10, 0), _mask([(-30, 30)]))
    assert p.state(0) is State.FOLLOW and calls == [0, 0]


def test_a_held_robot_waits_unmapped_until_released_and_a_finished_one_is_done():
    """hold: WAIT, zero commands, its scans stay out of its map; release: GOAL, it drives;
    finish: DONE, zero commands."""
    p, _ = _planner(LEFT, n=2, map_every=1)
    p.hold(1)
    safe = np.stack([_mask(), _mask([(-30, 30)])])
    ranges = np.where(safe, 3.0, 0.5)
    poses, goals = np.zeros((2, 3)), np.array([[10.0, 0.0], [10.0, 0.0]])
    cmd, _ = p.step(0.0, poses, goals, safe=safe, ranges_m=ranges, y1=ranges)
    assert cmd[1].tolist() == [0.0, 0.0] and p.state(1) is State.WAIT
    assert (p.maps.last_hit[0] >= 0).any() and not (p.maps.last_hit[1] >= 0).any()
    p.release(1)
    assert p.state(1) is State.GOAL
    cmd, _ = p.step(0.1, poses, goals, safe=safe, ranges_m=ranges, y1=ranges)
    assert cmd[1, 1] != 0.0 and p.state(1) is State.FOLLOW and (p.maps.last_hit[1] >= 0).any()
    p.finish(1)
    cmd, _ = p.step(0.2, poses, goals, safe=safe, ranges_m=ranges, y1=ranges)
    assert cmd[1].tolist() == [0.0, 0.0] and p.state(1) is State.DONE


def test_the_motions_default_is_the_configs():
    """motion_command's ``drive`` defaults to ``[planner]``'s (steered): driving at full speed
    within the tolerance, it turns toward the heading by the rotation command's rate."""
    import inspect

    default = inspect.signature(motion_command).parameters["drive"].default
    assert default == PlannerConfig().drive == "steered"
    kw = dict(tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0)
    assert motion_command(0.05, **kw) == motion_command(0.05, drive=PlannerConfig().drive, **kw)
    assert motion_command(0.05, **kw) == (0.5, 0.5) != motion_command(0.05, drive="straight",
                                                                      **kw)


def test_the_way_tolerance_applies_only_along_the_own_maps_way():
    """Blocked forever, as above: until the escape both planners command the same; while they
    steer along the own map's way, the one whose ``way_heading_tol_deg`` is 90 drives straight at
    every heading within 90 degrees, where the 3-degree one turns in place (straight motion,
    3 degrees elsewhere)."""
    paper = dict(loop_timeout_s=5.0, heading_tol_deg=3.0, drive="straight")
    narrow, _ = _planner(LEFT, way_heading_tol_deg=3.0, **paper)
    wide, _ = _planner(LEFT, way_heading_tol_deg=90.0, **paper)
    escaping = turned = 0
    for k in range(200):
        before = int(wide.stats.escape_ticks[0])
        a, _ = _step(narrow, 0.1 * k, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
        b, _ = _step(wide, 0.1 * k, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
        if wide.stats.escape_ticks[0] == before:  # not along the way: the shared tolerance
            assert a.tolist() == b.tolist()
            continue
        escaping += 1
        assert wide.state(0) is State.ESCAPE and b[0, 1] == 0.0 and b[0, 0] == 0.5
        turned += a[0, 0] == 0.0
    assert escaping > 100 and turned > 0


@given(target=st.floats(-math.pi, math.pi), tol_deg=st.floats(0.5, 90.0))
def test_steered_motion_closes_the_heading_error_that_straight_motion_keeps(target, tol_deg):
    """Both motions rotate in place beyond the tolerance and drive at full speed within it;
    there the steered one's yaw rate, integrated over one control period (the oracle: a
    unicycle's heading after 0.1 s), leaves an error no larger than the one it started from,
    and none where the yaw rate allows, while the straight one keeps the whole error."""
    kw = dict(tol_rad=math.radians(tol_deg), v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0)
    straight = motion_command(target, drive="straight", **kw)
    steered = motion_command(target, drive="steered", **kw)
    if abs(target) > kw["tol_rad"]:
        assert straight == steered and straight[0] == 0.0
        return
    assert straight == (0.5, 0.0) and steered[0] == 0.5
    left = target - steered[1] * 0.1
    assert abs(left) <= abs(target) + 1e-12 and abs(steered[1]) <= 1.5
    if abs(target) * 10.0 <= 1.5:
        assert left == pytest.approx(0.0, abs=1e-12)


def test_a_steered_robot_heads_for_its_goal_where_a_straight_one_stops_to_turn():
    """Open space, goal 9 degrees off the heading, tolerance 10, driven tick by tick (unicycle
    kinematics): the straight planner drives on 9 degrees off until the goal's bearing passes
    10 degrees, then stops and turns in place; the steered one never stops, and reaches the
    goal sooner on a line at most 0.5 % longer than the distance."""
    runs = {}
    for drive in ("straight", "steered"):
        p, _ = _planner(LEFT, heading_tol_deg=10.0, drive=drive)
        x, y, yaw, length, stops = 0.0, 0.0, math.radians(9.0), 0.0, 0
        for k in range(300):
            if math.hypot(10 - x, y) < 0.05:
                break
            cmd, _ = _step(p, 0.1 * k, (x, y, yaw), (10, 0), _mask())
            v, w = cmd[0]
            stops += v == 0.0
            yaw += w * 0.1
            x, y = x + v * 0.1 * math.cos(yaw), y + v * 0.1 * math.sin(yaw)
            length += v * 0.1
        runs[drive] = k, length, stops
    assert runs["straight"][2] > 0 and runs["steered"][2] == 0
    assert runs["steered"][0] < runs["straight"][0] and runs["steered"][1] <= 10 * 1.005


def test_near_goal_an_obstacle_behind_the_goal_does_not_block_it():
    p, calls = _planner(LEFT)
    safe = _mask([(-30, 30)])
    ranges = np.where(safe, 3.0, 0.5)[None]  # obstacle 0.5 m ahead, goal 0.3 m ahead
    cmd, blocked = p.step(0.0, np.array([[0, 0, 0.0]]), np.array([[0.3, 0]]), safe=safe[None],
                          ranges_m=ranges, y1=ranges)
    assert not blocked[0] and calls == [] and cmd.tolist() == [[0.5, 0.0]]


def test_no_safe_beam_rotates_toward_the_side_when_the_open_direction_is_too_close():
    p, _ = _planner(RIGHT)
    safe = np.zeros((1, M), bool)
    ranges = np.full((1, M), 0.2)
    y1 = ranges.copy()
    y1[0, 180] = 0.25  # most open straight ahead but only 0.2 m: cannot drive
    cmd = p.step(0.0, np.array([[0, 0, 0.0]]), np.array([[10, 0]]), safe=safe, ranges_m=ranges,
                 y1=y1)[0]
    assert cmd.tolist() == [[0.0, -1.5]]


def test_done_robots_get_zero_commands():
    p, _ = _planner(LEFT, n=2)
    p.finish(1)
    safe = np.stack([_mask(), _mask()])
    cmd = p.step(0.0, np.zeros((2, 3)), np.array([[10, 0], [10, 0]]), safe=safe,
                 ranges_m=safe * 3.0, y1=safe * 1.0)[0]
    assert cmd[1].tolist() == [0.0, 0.0] and cmd[0].tolist() == [0.5, 0.0]


def test_policy_must_return_a_side():
    p = BugPlanner(1, l_th_m=0.6, r0_m=0.15, fov_rad=FOV, decide=lambda i: 0)
    with pytest.raises(ValueError, match=r"a policy must return \+1 \(left\) or -1 \(right\), got 0"):
        _step(p, 0.0, (0, 0, 0), (10, 0), _mask([(-30, 30)]))


def test_bad_params_are_named():
    with pytest.raises(ValueError, match=r"v_max_mps must be a finite number > 0, got v_max_mps=0"):
        PlannerParams(v_max_mps=0)


def test_corridor_free_blocks_exactly_the_headings_whose_corridor_holds_the_point():
    from fftnav.navigation.bug import corridor_free

    ang = -math.pi + np.arange(M) * 2 * math.pi / M
    ranges = np.zeros((2, M))  # zero readings are not points
    ranges[0, 200] = 0.21  # one point 0.21 m away at +20 degrees
    free = corridor_free(ranges, ang, half_width_m=0.1, lookahead_m=0.25)
    rel = ang - ang[200]
    # analytic: blocked iff 0 < 0.21 cos(rel) <= 0.25 and |0.21 sin(rel)| < 0.1 (|rel| < 28.4 deg)
    expected_blocked = np.abs(rel) < math.asin(0.1 / 0.21)
    np.testing.assert_array_equal(~free[0], expected_blocked)
    assert free[1].all()


def test_stall_fallback_turns_one_way_until_it_faces_the_only_opening():
    """Enclosed at 0.28 m except a 90 degree opening at +120 deg that reads 0.5 m (< l_th, so no
    beam is safe): with side right the robot must keep turning right (never back and forth) and
    then drive into the opening."""
    p, _ = _planner(RIGHT)
    ang = -math.pi + np.arange(M) * 2 * math.pi / M
    yaw, dt, ws, drove_at = 0.0, 0.1, [], None
    for tick in range(60):
        world_dir = np.degrees((ang + yaw + math.pi) % (2 * math.pi) - math.pi)
        ranges = np.where(np.abs(world_dir - 120.0) < 45.0, 0.5, 0.28)[None]
        safe = np.zeros((1, M), bool)  # nothing reads l_th = 0.6 m
        y1 = np.minimum(ranges, 0.6) / 3.0
        cmd = p.step(0.1 * tick, np.array([[0, 0, yaw]]), np.array([[10, 0]]), safe=safe,
                     ranges_m=ranges, y1=y1)[0][0]
        if cmd[0] > 0:
            drove_at = yaw
            break
        ws.append(cmd[1])
        yaw += cmd[1] * dt
    assert ws and all(w < 0 for w in ws)
    assert drove_at is not None
    assert abs(((math.degrees(drove_at) - 120.0) + 180) % 360 - 180) < 10.0


def test_partial_field_of_view_uses_its_own_beam_angles():
    """180 deg lidar, 181 beams: a point 0.25 m away at +30 deg blocks driving straight ahead
    (it lies within r0 + clearance of the path) although every beam is 'safe'."""
    fov = math.pi
    p = BugPlanner(1, l_th_m=0.6, r0_m=0.15, fov_rad=fov, decide=lambda i: LEFT)
    ranges = np.full((1, 181), 3.0)
    ranges[0, 120] = 0.25  # beam 120 of 181 over 180 deg is at +30 deg
    cmd, blocked = p.step(0.0, np.array([[0, 0, 0.0]]), np.array([[10, 0]]),
                          safe=np.ones((1, 181), bool), ranges_m=ranges, y1=ranges / 3.0)
    assert blocked[0] and cmd[0, 0] == 0.0
    # a goal behind a 180 degree lidar is not "blocked": the robot turns to look at it
    p2 = BugPlanner(1, l_th_m=0.6, r0_m=0.15, fov_rad=fov, decide=lambda i: LEFT)
    cmd, blocked = p2.step(0.0, np.array([[0, 0, 0.0]]), np.array([[-10, 1]]),
                           safe=np.ones((1, 181), bool), ranges_m=np.full((1, 181), 3.0),
                           y1=np.ones((1, 181)))
    assert not blocked[0] and cmd[0, 0] == 0.0 and cmd[0, 1] == 1.5



def test_every_policy_still_escapes_a_pocket_open_toward_it():
    """A U pocket 4 m wide and 2 m deep right in the way: the robot walks in and out round an
    arm by escaping through its own map."""
    import math

    from fftnav.config import EpisodeConfig, SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.world import World
    from fftnav.world.obstacles import rectangle

    pocket = (rectangle(2.0, 5.0, 6.3, 5.3, 1.0), rectangle(2.0, 3.0, 2.3, 5.0, 1.0),
              rectangle(6.0, 3.0, 6.3, 5.0, 1.0))
    world = World("t", 0, (8.3, 10.0), pocket, np.array([[4.15, 1.0, math.pi / 2]]),
                  np.array([[4.15, 9.0]]), "walls")
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=80.0))
    for policy in ("bug-left", "bug-right", "own-only"):
        row = run_episode(world, policy, seed=0, config=cfg).rows[0]
        assert row.arrived and not row.collided, policy
        assert row.escape_time_s > 0 and row.path_length_m < 20.0, policy


def test_tried_sides_memory_takes_the_other_side_only_without_progress():
    planner = BugPlanner(1, l_th_m=0.6, r0_m=0.15, fov_rad=2 * np.pi, decide=lambda i: 1)
    memory = planner.memory[0]
    memory.hits.append(Hit(2.0, 3.0, 10.0, 1))  # passed left at (2, 3), 10 m from the goal

    def tried(xy, dist):
        return memory.tried_side(np.array(xy), dist, radius_m=planner.params.memory_radius_m,
                                 progress_m=planner.params.progress_m)

    assert tried([2.5, 3.2], 10.0) == -1  # back, no progress
    assert tried([2.5, 3.2], 9.0) is None  # progress made
    assert tried([3.5, 3.0], 10.0) is None  # elsewhere
    memory.hits.append(Hit(2.2, 3.0, 10.2, -1))  # the latest try there went right
    assert tried([2.1, 3.0], 10.3) == 1


def test_a_robot_on_the_wrong_side_of_a_wall_joined_to_the_map_edge_turns_back():
    """A wall from the left map edge to 2 m short of the right one, 3 m ahead: bug-left runs
    into the corner with the edge (a dead end whose contour is the whole map edge), escapes
    through its own map back along the wall and round its free end. Oracle: grid A*'s
    shortest length (the reference of SPL); the robot arrives within 2.2 times it (the way
    into the corner and back is part of the price of the wrong side)."""
    from fftnav.config import EpisodeConfig, SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.optimal.reference import optimal_lengths
    from fftnav.world import World
    from fftnav.world.obstacles import rectangle

    wall = (rectangle(0.0, 4.0, 8.0, 4.25, 1.0),)
    world = World("t", 0, (10.0, 8.0), wall, np.array([[3.0, 1.0, math.pi / 2]]),
                  np.array([[3.0, 7.0]]), "walls")
    optimal = float(optimal_lengths(world, r0_m=0.15)[0][0])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=90.0))
    rows = {}
    for policy in ("bug-left", "bug-right"):
        rows[policy] = row = run_episode(world, policy, seed=0, config=cfg).rows[0]
        assert row.arrived and not row.collided, policy
        assert row.path_length_m < 2.2 * optimal, (policy, row.path_length_m, optimal)
    assert rows["bug-left"].escape_time_s > 0
    assert rows["bug-right"].path_length_m < rows["bug-left"].path_length_m


def test_an_escape_whose_way_does_not_shorten_closes_it_and_plans_another():
    """A robot held in place in escape (its way never gets shorter): every escape_bound_s
    after the escape began it closes the next escape_block_m of its way in its own map, counts
    a loop detection, and its way is replanned round the closed cells (it gets longer). A robot
    that drives along its way, shortening it, never closes it."""
    p, _ = _planner(LEFT, loop_timeout_s=5.0, escape_bound_s=15.0)
    flips_at, ways = [], []
    for k in range(500):
        t = 0.1 * k
        before = int(p.stats.loop_flips[0])
        _step(p, t, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
        if p.stats.loop_flips[0] > before:
            flips_at.append(round(t, 1))
            ways.append(p.maps.way_length(0, np.zeros(2)))
    # the escape begins at 5.1 s; its way is planned every second and found no shorter
    assert flips_at[0] == pytest.approx(5.1)
    assert flips_at[1:] == pytest.approx([21.1, 37.1])
    assert p.maps.blocked[0].sum() > 0 and ways[2] > ways[1] > 10.0 - 0.2

    moving, _ = _planner(LEFT, loop_timeout_s=5.0, escape_bound_s=15.0)
    for k in range(500):
        x = min(max(0.0, 0.01 * (k - 60)), 4.0)  # drives along its way once escaping
        _step(moving, 0.1 * k, (x, 0, 0), (10, 0), _mask([(-30, 30)]))
    assert moving.state(0) is State.ESCAPE and moving.stats.loop_flips[0] == 1
    assert not moving.maps.blocked[0].any()


def test_two_robots_that_close_each_others_pocket_squeeze_out(monkeypatch):
    """Fresh traps map 71 under collab, the paper's setting, with its robots mapping each other
    as obstacles (OwnMaps.set_robots switched off: as own-only's and fusion's robots always
    do): robots 2 and 3 end side by side in a trap's corner by a rock, and the clearance
    closes each one's pocket. Without the squeezed plan (map_squeeze_m = map_clearance_m) both
    turn on the spot until the time limit: a jam. With the default squeeze, once they have
    stayed put for squeeze_after_s, both plan a narrower way out and every robot arrives.
    (collab's guided way is switched off too: it keeps these robots out of that corner.)"""
    from fftnav.config import PAPER_MOTION, SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.navigation import bug
    from fftnav.navigation.messages import Walls
    from fftnav.navigation.ownmap import OwnMaps
    from fftnav.runner.tasks import episode_seed
    from fftnav.world.generate import generate_world

    maps = []
    init = OwnMaps.__init__

    def keep(self, *args, **kwargs):
        init(self, *args, **kwargs)
        maps.append(self)

    monkeypatch.setattr(OwnMaps, "__init__", keep)
    monkeypatch.setattr(OwnMaps, "set_robots", lambda self, robot, xy: None)
    monkeypatch.setattr(Walls, "guides", lambda self, swarm, robot: False)
    world = generate_world("traps", 71, robots=15)
    seed = episode_seed("traps", 71)
    # the robots end in that corner with the paper's motion (straight, or rotation in place
    # beyond 3 degrees of heading error); the default steered motion takes them elsewhere
    paper = SwarmConfig().replace(PAPER_MOTION)
    rows = run_episode(world, "collab", seed=seed, config=paper).rows
    assert all(r.arrived for r in rows)
    assert maps[0].squeezes[2] > 0 and maps[0].squeezes[3] > 0
    for_swarm = bug.PlannerParams.for_swarm.__func__

    def no_squeeze(cls, config, **constants):
        return for_swarm(cls, config, map_squeeze_m=bug.PlannerParams().map_clearance_m,
                         **constants)

    monkeypatch.setattr(bug.PlannerParams, "for_swarm", classmethod(no_squeeze))
    rows = run_episode(world, "collab", seed=seed, config=paper).rows
    assert [(r.robot, r.failure) for r in rows if not r.arrived] == [(2, "jam"), (3, "jam")]


def test_a_robot_with_the_right_of_way_waits_only_boxed_in_and_at_most_give_way_s():
    """``wait`` is asked only when the goal direction is blocked and no safe heading lies within
    90 degrees of it; a robot that goes first then stands still (no decision) for at most
    give_way_s in one place, and decides as usual after that, or when ``wait`` says no."""
    asked = []

    def wait(i):
        asked.append(i)
        return True

    p, calls = _planner(LEFT, give_way_s=2.0)
    p.wait = wait
    # blocked ahead, but the sides are open: it takes a side at once, wait not asked
    cmd, _ = _step(p, 0.0, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
    assert asked == [] and calls == [0] and p.state(0) is State.FOLLOW
    p, calls = _planner(LEFT, give_way_s=2.0)
    p.wait = wait
    boxed = _mask([(-100, 100)])  # only the rear half open: going on means turning back
    for k in range(20):  # 2 s standing in one place
        cmd, blocked = _step(p, 0.1 * k, (0, 0, 0), (10, 0), boxed)
        assert cmd.tolist() == [[0.0, 0.0]] and blocked[0]
    assert calls == [] and p.stats.wait_ticks[0] == 20 and p.state(0) is State.WAIT
    cmd, _ = _step(p, 2.0, (0, 0, 0), (10, 0), boxed)  # waited give_way_s: decides
    assert calls == [0] and cmd[0, 1] != 0.0 and len(asked) == 20
    p, calls = _planner(LEFT)
    p.wait = lambda i: False  # it gives way: decides at once
    _step(p, 0.0, (0, 0, 0), (10, 0), boxed)
    assert calls == [0]


def test_a_guided_robot_steers_round_a_known_wall_and_gives_the_way_up_when_it_leads_nowhere():
    """With ``guide``, a robot heading for its goal whose map shows a wall across the straight
    line (its way more than guide_margin_m longer than the grid distance) turns toward the way
    round it, although its scan shows nothing; without the wall, or without ``guide``, it
    drives straight. Held in place (its way never gets shorter), it gives the way up after
    guide_bound_s and heads for the goal until it is R closer."""

    def planner(**kw):
        p = BugPlanner(1, l_th_m=0.6, r0_m=0.15, fov_rad=FOV, decide=lambda i: LEFT,
                       params=PlannerParams(**kw), area_m=(12.0, 12.0))
        p.guide = lambda i: True
        return p

    wall = np.array([[[6.0, 0.0], [6.0, 9.0]]])  # x = 6 m, from y = 0 to 9 m
    start, goal = (2.0, 6.0, 0.0), (10.0, 6.0)
    p = planner()
    cmd, _ = _step(p, 0.0, start, goal, _mask())
    assert cmd.tolist() == [[0.5, 0.0]] and p.stats.guided_ticks[0] == 0  # nothing known: straight
    p.maps.add_walls(0, 1, wall)
    cmd, _ = _step(p, 1.0, start, goal, _mask())
    assert cmd[0, 0] == 0.0 and cmd[0, 1] > 0  # turns left, toward the way over the wall's end
    assert p.stats.guided_ticks[0] == 1 and p.state(0) is State.GUIDED
    unguided = planner()
    unguided.guide = None
    _step(unguided, 0.0, start, goal, _mask())
    unguided.maps.add_walls(0, 1, wall)
    cmd, _ = _step(unguided, 1.0, start, goal, _mask())
    assert cmd.tolist() == [[0.5, 0.0]]
    p = planner(guide_bound_s=3.0)
    _step(p, 0.0, start, goal, _mask())
    p.maps.add_walls(0, 0, wall)
    for k in range(10, 56):  # in place from 1 s: plans at 1, 2, ... s; gives up at 5 s
        cmd, _ = _step(p, 0.1 * k, start, goal, _mask())
        if k < 50:
            assert cmd[0, 0] == 0.0 and cmd[0, 1] > 0 and p.stats.guides_quit[0] == 0
        else:
            assert cmd.tolist() == [[0.5, 0.0]] and p.stats.guides_quit[0] == 1
    cmd, _ = _step(p, 7.0, (4.0, 6.0, 0.0), goal, _mask())  # 2 m closer: still straight
    assert cmd.tolist() == [[0.5, 0.0]] and not p.memory[0].ways.guided
    assert p.state(0) is State.GOAL
    p.maps.add_walls(0, 10**6, wall)  # seen again (the scans of this test see nothing)
    cmd, _ = _step(p, 8.0, (5.5, 7.0, 0.0), goal, _mask())  # more than R closer: guided again
    assert p.memory[0].ways.guided and p.state(0) is State.GUIDED


def test_a_robot_the_planner_may_guide_escapes_through_the_walls_and_gives_up_sooner():
    """With a guide hook that says yes (collab's open gate), the escape of a robot held in
    place plans through the walls of its map only: the scan hits all round it are not in its
    way, which is the grid distance to the goal (10 m), where the plan through every hit goes
    round them. And a way that does not shorten is closed after guide_bound_s (5 s here), not
    escape_bound_s (15 s): every 6 s instead of every 16 s (plans are a second apart)."""

    def flips(guide):
        p = BugPlanner(1, l_th_m=0.6, r0_m=0.15, fov_rad=FOV, decide=lambda i: LEFT,
                       params=PlannerParams(loop_timeout_s=5.0, escape_bound_s=15.0,
                                            guide_bound_s=5.0), guide=guide)
        at, ways = [], []
        for k in range(300):
            before = int(p.stats.loop_flips[0])
            _step(p, 0.1 * k, (0, 0, 0), (10, 0), _mask([(-30, 30)]))
            if p.stats.loop_flips[0] > before:
                at.append(0.1 * k)
                ways.append(p.maps.way_length(0, np.zeros(2)))
        return at, ways

    at, ways = flips(None)
    assert at == pytest.approx([5.1, 21.1]) and ways[0] > 10.0 + 0.2
    at, ways = flips(lambda i: True)
    assert at == pytest.approx([5.1, 10.1, 16.1, 22.1, 28.1])
    assert ways[0] == pytest.approx(10.0)
