"""SwarmNavEnv.render(): the replays' frame code on the environment's current tick: the map
with its border, the picked robot's scan and safe sectors (to l_th), failed robots' crosses and
causes, and the key below the map (clock, the picked robot's state, scale bar, legend); a fixed
size per world and the same bytes for the same episode."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")

from matplotlib.colors import to_rgb  # noqa: E402

from fftnav.envs import Observations, SwarmNavEnv  # noqa: E402
from fftnav.report.frames import (  # noqa: E402
    KIND_COLOURS,
    SAFE_ALPHA,
    SAFE_COLOUR,
    kind_rgb,
    scale_bar_m,
)
from fftnav.world import Circle, World  # noqa: E402

UP = math.pi / 2
RES = 0.05
#: 12 m x 8 m; robot 0 at (3, 2) facing a trunk whose near edge is 1.5 m ahead (y = 3.5);
#: robot 1 at (9, 2) facing up, nothing ahead; robot 2 drives into the trunk at (9, 5).
WORLD = World("test", 0, (12.0, 8.0),
              (Circle((3.0, 4.0), 0.5, 1.0), Circle((9.0, 5.0), 0.5, 1.0)),
              np.array([[3.0, 2.0, UP], [6.0, 1.0, 0.0], [9.0, 3.5, UP]]),
              np.array([[3.0, 7.5], [11.0, 1.0], [9.0, 7.5]]))


def _env(**options):
    env = SwarmNavEnv(world=WORLD, render_mode="rgb_array",
                      observations=Observations(safe_mask=True))
    env.reset(seed=0, options={"time_limit_s": 4.0, **options})
    return env


def _at(frame: np.ndarray, x: float, y: float) -> np.ndarray:
    """The map pixel of the world point (x, y): the first rows are the map, 5 cm a pixel."""
    h = WORLD.size_m[1]
    return frame[int((h - y) / RES), int(x / RES)].astype(int)


def _near(frame: np.ndarray, x: float, y: float, px: int = 3) -> np.ndarray:
    h = WORLD.size_m[1]
    row, col = int((h - y) / RES), int(x / RES)
    return frame[row - px:row + px + 1, col - px:col + px + 1].astype(int)


def test_render_draws_the_picked_robots_scan_and_safe_sectors_to_l_th():
    """Robot 0's returns on the trunk's near edge 1.5 m ahead are near-black dots, its safe
    sectors green out to l_th = 0.6 m (its left, 0.4 m away) and not beyond (1.0 m); with no
    robot picked, neither is drawn, and the rest of the map is the same."""
    env = _env()
    picked = env.render()
    env.render_robot = None
    plain = env.render()
    env.close()
    assert picked.shape == plain.shape
    rows = round(WORLD.size_m[1] / RES)
    edge = [_near(picked, 3.0 + 1.5 * math.sin(a), 2.0 + 1.5 * math.cos(a))
            for a in np.radians([-8, 0, 8])]
    assert all((e.max(axis=-1) < 30).any() for e in edge)  # the returns (obstacle edges: 51)
    assert not any((_near(plain, 3.0 + 1.5 * math.sin(a), 2.0 + 1.5 * math.cos(a))
                    .max(axis=-1) < 30).any() for a in np.radians([-8, 0, 8]))
    green = 255 * (SAFE_ALPHA * np.array(to_rgb(SAFE_COLOUR)) + 1 - SAFE_ALPHA)
    for left_m in (0.45, 0.5, 0.55):  # to its left, beyond its ring, within l_th = 0.6 m
        assert np.abs(_at(picked, 3.0 - left_m, 2.0) - green).max() <= 3, left_m
        assert tuple(_at(plain, 3.0 - left_m, 2.0)) == (255, 255, 255)
    for left_m in (0.65, 1.0, 2.0):  # beyond l_th: no sector
        assert tuple(_at(picked, 3.0 - left_m, 2.0)) == (255, 255, 255), left_m
    far = np.abs(picked[:rows].astype(int) - plain[:rows].astype(int)).max(axis=-1) > 0
    rr, cc = np.nonzero(far)  # what changed lies round robot 0, within its sensor range
    x, y = (cc + 0.5) * RES, WORLD.size_m[1] - (rr + 0.5) * RES
    assert np.hypot(x - 3.0, y - 2.0).max() <= 3.0 + 0.2


def test_render_has_its_key_a_border_and_a_fixed_size():
    """Below the map, a scale bar of scale_bar_m(12) = 2 m (40 pixels); the world's border on
    the map's edge pixels; the same size at every tick."""
    env = _env()
    first = env.render()
    rows = round(WORLD.size_m[1] / RES)
    key = first[rows:]
    runs = [max((len(run) for run in np.split(np.arange(key.shape[1]),
                                               np.flatnonzero(np.diff(dark)) + 1)
                 if dark[run[0]]), default=0)
            for dark in (key.max(axis=-1) < 60)]
    assert scale_bar_m(12.0) == 2.0 and abs(max(runs) - 40) <= 1
    for edge in (first[0, 10:-10], first[rows - 1, 10:-10], first[10:rows - 10, 0],
                 first[10:rows - 10, -1]):
        assert (edge.max(axis=-1) < 60).all()  # the border, all round
    for _ in range(5):
        env.step({a: np.array([0.2, 0.0], np.float32) for a in env.agents})
        assert env.render().shape == first.shape
    env.close()


def test_render_is_the_same_bytes_for_the_same_episode():
    frames = []
    for _ in range(2):
        env = _env(controller="bug-left")
        for _ in range(8):
            commands, outgoing = env.controller.step(env.core.swarm)
            env.step({a: commands[env.index(a)] for a in env.agents},
                     messages={env.possible_agents[i]: m for i, m in outgoing.items()})
        frames.append(env.render())
        env.close()
    assert np.array_equal(frames[0], frames[1])


def test_render_names_the_clock_the_state_and_the_failure_causes():
    """The key's clock (t over the 4 s limit) and robot 0's planner state by its name; robot 2
    driven into its trunk is red with a red cross and its cause, collision, as in the rows."""
    env = _env(controller="bug-left")
    for _ in range(12):
        commands, outgoing = env.controller.step(env.core.swarm)
        env.step({a: commands[env.index(a)] for a in env.agents})
    env.render()
    key = env._renderer.painter.key  # the drawn key's texts
    assert key.clock.get_text() == "t = 1.2 s / 4 s"
    mode = env.controller.state(0)["mode"]
    side = env.controller.state(0)["side"]
    from fftnav.states import State

    name = State(int(mode)).label + ({1: " (left)", -1: " (right)"}.get(int(side), ""))
    assert key.robot.get_text() == f"robot 0: {name}"
    env.close()
    env = _env()
    while env.agents:  # every robot straight ahead: robot 2 into the trunk 1 m ahead
        _, _, term, _, info = env.step({a: np.array([0.5, 0.0], np.float32) for a in env.agents})
        if "robot_2" in info and info["robot_2"]["collided"]:
            assert term["robot_2"]
    frame = env.render()
    labels = [t.get_text() for t in env._renderer.painter.labels]
    assert "collision" in labels
    x, y = env.core.trajectories()[2][-1, :2]
    assert tuple(_at(frame, x, y)) == kind_rgb("failed")
    arms = [_at(frame, x + sx * 0.2, y + sy * 0.2) for sx in (-1, 1) for sy in (-1, 1)]
    red = np.array(kind_rgb("failed"))
    assert sum(np.abs(a - red).max() < 40 for a in arms) >= 3  # the cross, beyond the disc
    assert KIND_COLOURS["failed"] == "#d62728"
    env.close()


def test_render_robot_is_checked():
    env = SwarmNavEnv(world=WORLD, render_mode="rgb_array")
    with pytest.raises(ValueError, match=r"render_robot must be an integer >= 0, got "
                                         r"render_robot=-1"):
        env.render_robot = -1
    env.render_robot = 7  # a robot the world does not have: none is drawn
    env.reset(seed=0)
    assert env.render().ndim == 3
    env.close()
