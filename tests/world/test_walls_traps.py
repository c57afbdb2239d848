"""World kinds walls and traps, the map boundary and departure schedules."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import ndimage

from fftnav.config import EpisodeConfig, SwarmConfig
from fftnav.optimal.gridgraph import UnreachableGoalError
from fftnav.optimal.reference import optimal_lengths
from fftnav.runner.config import parse_config
from fftnav.sim.swarm import SwarmSim
from fftnav.world import Polygon, World, generate_world, load_world, raycast_world
from fftnav.world.grid import occupancy_grid

SEEDS = range(8)


def _reachable(world: World, radius: float, res: float = 0.1) -> bool:
    """Oracle: every goal in the start's 8-connected component of cells whose centre keeps
    ``radius`` (plus half a cell diagonal) from every solid, computed here from distances."""
    w, h = world.size_m
    xs, ys = np.arange(res / 2, w, res), np.arange(res / 2, h, res)
    gx, gy = np.meshgrid(xs, ys)
    free = (world.obstacle_distance(np.c_[gx.ravel(), gy.ravel()]) > radius + res)
    labels, _ = ndimage.label(free.reshape(gx.shape), structure=np.ones((3, 3)))

    def label(p):
        return labels[int(p[1] / res), int(p[0] / res)]

    return all(label(s) and label(s) == label(g) for s, g in zip(world.starts, world.goals, strict=True))


@pytest.mark.parametrize("env", ["walls", "traps"])
def test_generated_worlds_are_seeded_reachable_with_clear_strips_and_boundary_walls(env):
    for seed in SEEDS:
        world = generate_world(env, seed)
        assert world.boundary == "walls" and len(world.boundary_walls) == 2 * 9 + 2 * 8
        assert world.to_json() == generate_world(env, seed).to_json()  # seeded
        assert World.from_json(world.to_json()).to_json() == world.to_json()
        for o in world.obstacles:  # strips |y - 1| <= 1 and |y - 19| <= 1 clear, inside the map
            lo, hi = o.bounds()
            assert lo[1] >= 2.0 - 1e-9 and hi[1] <= 18.0 + 1e-9
            assert lo[0] >= -1e-9 and hi[0] <= 20.0 + 1e-9
        assert _reachable(world, 0.15), (env, seed)
    assert generate_world(env, 0).to_json() != generate_world(env, 1).to_json()


def test_walls_have_barriers_longer_than_the_range_with_gaps():
    for seed in SEEDS:
        world = generate_world("walls", seed)
        walls = [o for o in world.obstacles if isinstance(o, Polygon)]
        lengths = [np.ptp(np.asarray(o.vertices)[:, 0]) for o in walls]
        assert max(lengths) >= 6.0 and max(lengths) <= 9.0 + 1e-9  # 2-3 R for R = 3 m
        rows = sorted({round(float(np.mean(np.asarray(o.vertices)[:, 1])), 3) for o in walls})
        assert len(rows) == 2
        for y in rows:  # every row leaves a gap of at least 1.2 m somewhere across the map
            xs = [np.asarray(o.vertices)[:, 0] for o in walls
                  if abs(np.mean(np.asarray(o.vertices)[:, 1]) - y) < 1e-3]
            spans = sorted((x.min(), x.max()) for x in xs)
            edges = [0.0] + [v for s in spans for v in s] + [20.0]
            gaps = [b - a for a, b in zip(edges[::2], edges[1::2], strict=True)]
            assert max(gaps) >= 1.2 - 1e-9


def test_traps_are_concave_pockets_of_two_or_three_walls():
    world = generate_world("traps", 3)
    walls = [o for o in world.obstacles if isinstance(o, Polygon)]
    assert 6 * 2 <= len(walls) <= 6 * 3
    # a pocket: some point with walls on three sides within 3.5 m (a U) exists
    pts = np.random.default_rng(0).uniform([0, 2], [20, 18], (4000, 2))
    angles = np.linspace(-math.pi, math.pi, 72, endpoint=False)
    d = raycast_world(world, pts, np.tile(angles, (len(pts), 1)), 4.0)
    blocked = (d < 3.5).mean(axis=1)
    assert blocked.max() >= 0.7


def test_world_kind_parameters_are_checked():
    with pytest.raises(ValueError, match=r"barrier_gap_m\[0\] must be a finite number > 0"):
        generate_world("walls", 0, barrier_gap_m=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"open_to_start must be a finite number in \[0, 1\]"):
        generate_world("traps", 0, open_to_start=2.0)
    with pytest.raises(ValueError, match=r"boundary must be one of \['open', 'walls'\], got "
                                         r"boundary='wall'"):
        generate_world("forest", 0, boundary="wall")
    assert generate_world("forest", 0, boundary="walls").boundary == "walls"


def _corridor(boundary):
    """6 m x 6 m, a wall across y = 3 leaving 0.2 m at the left edge; one robot below it."""
    wall = Polygon(((0.2, 2.9), (6.0, 2.9), (6.0, 3.1), (0.2, 3.1)), 1.0)
    return World("t", 0, (6.0, 6.0), (wall,), np.array([[3.0, 1.0, 0.0]]),
                 np.array([[3.0, 5.0]]), boundary)


def test_boundary_walls_block_grid_and_astar_at_the_edge():
    open_world, walled = _corridor("open"), _corridor("walls")
    # a disc of 0.12 m passes the 0.2 m slit only in the open world (along the map edge)
    assert np.isfinite(optimal_lengths(open_world, r0_m=0.12, resolution_m=0.02)[0][0])
    with pytest.raises(UnreachableGoalError):
        optimal_lengths(walled, r0_m=0.12, resolution_m=0.02)
    grid_open = occupancy_grid(open_world, resolution_m=0.1, inflate_m=0.3).grid
    grid_walled = occupancy_grid(walled, resolution_m=0.1, inflate_m=0.3).grid
    assert not grid_open[5:25, 0:3].any()  # cells within 0.3 m of the left edge, below the wall
    assert grid_walled[5:25, 0:3].all() and not grid_walled[5:25, 3:27].any()


def test_boundary_walls_are_seen_by_the_lidar_and_the_ray_cast_oracle():
    starts = np.array([[1.0, 2.0, 0.0]])
    for boundary, expected in (("open", 3.0), ("walls", 1.0)):
        world = World("t", 0, (6.0, 6.0), (), starts, np.array([[5.0, 5.0]]), boundary)
        with SwarmSim(world) as sim:
            scan = sim.reset(seed=0).scans[0]
        back_left = np.argmin(np.abs(np.linspace(-math.pi, math.pi, 360, endpoint=False)
                                     - (-math.pi + 10 * math.pi / 180)))  # outside the blind sector
        ray = -math.pi + 10 * math.pi / 180
        oracle = raycast_world(world, starts[:, :2], [[ray]], 3.0)[0, 0]
        assert oracle == pytest.approx(min(3.0, 1.0 / math.cos(10 * math.pi / 180))
                                       if boundary == "walls" else 3.0)
        assert scan[back_left] == pytest.approx(oracle, abs=0.01)
        down = np.argmin(np.abs(np.linspace(-math.pi, math.pi, 360, endpoint=False) + math.pi / 2))
        assert scan[down] == pytest.approx(2.0 if boundary == "walls" else 3.0, abs=0.01)
        assert expected == pytest.approx(1.0 if boundary == "walls" else 3.0)


def test_robot_driven_into_the_boundary_collides_only_with_walls():
    for boundary in ("open", "walls"):
        world = World("t", 0, (6.0, 6.0), (), np.array([[1.0, 3.0, math.pi]]),
                      np.array([[5.0, 3.0]]), boundary)
        with SwarmSim(world) as sim:
            sim.reset(seed=0)
            hit = False
            for _ in range(40):  # 2 m toward -x at 0.5 m/s
                obs = sim.step([[0.5, 0.0]])
                hit |= bool(obs.obstacle_contact[0])
        if boundary == "walls":
            assert hit and obs.poses[0, 0] > 0.15 - 0.005
        else:
            assert not hit and obs.poses[0, 0] < -0.9


def test_world_files_keep_their_meaning_and_refuse_unknown_keys(tmp_path):
    world = _corridor("open")
    data = json.loads(world.to_json())
    assert "boundary" not in data  # an open world's file is what it always was
    assert json.loads(_corridor("walls").to_json())["boundary"] == "walls"
    path = tmp_path / "w.json"
    path.write_text(json.dumps(data))
    assert load_world(path).boundary == "open"
    path.write_text(json.dumps({**data, "boundary": "walls"}))
    assert load_world(path).boundary == "walls"
    path.write_text(json.dumps({**data, "boundary": "fence"}))
    with pytest.raises(ValueError, match=r"boundary must be one of \['open', 'walls'\], got "
                                         r"boundary='fence'"):
        load_world(path)
    path.write_text(json.dumps({**data, "edge": "walls"}))
    with pytest.raises(ValueError, match="world file has an unknown key 'edge'"):
        load_world(path)
    path.write_text(json.dumps({**data, "boundary": "walls", "starts": [[0.0, 1.0, 0.0]]}))
    with pytest.raises(ValueError, match=r"starts\[0\] lies inside a boundary wall"):
        load_world(path)


def _experiment(**sections):
    base = {"experiment": {"name": "t", "envs": ["walls", "traps"], "maps": 1, "map_seed": 0,
                           "robots": 15, "policies": ["fusion"]}}
    return parse_config({**base, **sections})


def test_configs_take_boundary_and_departures_and_refuse_unknown_keys():
    cfg = _experiment(world={"boundary": "open"},
                      episode={"departure": "waves", "waves": 2, "wave_interval_s": 5.0})
    assert cfg.world_overrides("walls")["boundary"] == "open"
    assert cfg.swarm.episode.departure_ticks(4) == [0, 50, 0, 50]
    with pytest.raises(ValueError, match=r"\[world\] for env 'walls': boundary must be one of"):
        _experiment(world={"boundary": "fence"})
    with pytest.raises(ValueError, match=r"unknown key world.fence"):
        _experiment(world={"fence": 1})
    with pytest.raises(ValueError, match=r"episode.departure must be one of \['together', "
                                         r"'waves', 'staggered'\], got episode.departure='later'"):
        _experiment(episode={"departure": "later"})
    with pytest.raises(ValueError, match=r"unknown key episode.wave_size"):
        _experiment(episode={"wave_size": 3})
    with pytest.raises(ValueError, match=r"episode.waves must be an integer >= 1"):
        SwarmConfig().replace({"waves": 0})


def test_staggered_robots_wait_still_and_their_time_counts_from_departure(monkeypatch):
    from fftnav.episode import run_episode

    commands = []
    step = SwarmSim.step

    def spy(self, cmd):
        commands.append(np.array(cmd, dtype=float))
        return step(self, cmd)

    monkeypatch.setattr(SwarmSim, "step", spy)
    world = World("t", 0, (6.0, 6.0), (), np.array([[1.5, 1.0, math.pi / 2],
                                                    [4.5, 1.0, math.pi / 2]]),
                  np.array([[1.5, 4.0], [4.5, 4.0]]))
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=8.0, departure="staggered",
                                            stagger_s=5.0))
    rows = run_episode(world, "bug-left", seed=0, config=cfg).rows
    cmd = np.array(commands)
    assert not cmd[:50, 1].any() and cmd[50:, 1].any()  # robot 1 still for its first 5 s
    assert cmd[:10, 0].any()
    # 2.7 m at 0.5 m/s: 5.4 s, within 8 s of each robot's own departure (not of the episode's)
    assert rows[0].arrived and rows[1].arrived
    assert rows[1].time_s == pytest.approx(rows[0].time_s, abs=0.11)
    assert rows[1].path_length_m == pytest.approx(rows[0].path_length_m, abs=0.06)
