"""The learned controller: observation builders element by element, the action spec, the
``learned:PATH.npz`` name, its refusals, and tiny episodes driven by saved networks."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fftnav.config import CommsConfig, EpisodeConfig, SensorConfig, SwarmConfig
from fftnav.episode import run_episode
from fftnav.errors import FftnavError
from fftnav.navigation.controllers import ControllerSetup, Packet, RobotObservation
from fftnav.navigation.learned import (
    EXTREMA,
    NEIGHBOURS,
    OBSERVATIONS,
    extrema_slots,
    untrained,
)
from fftnav.navigation.mlp import MLP
from fftnav.navigation.resolve import resolve
from fftnav.observe.codec import encode_sigma
from fftnav.runner import parse_config
from fftnav.runner.resume import canonical_config
from fftnav.world import World

UP = math.pi / 2
R = 3.0
BEAMS = 8
CFG = SwarmConfig(sensor=SensorConfig(beams=BEAMS, range_m=R))
EMPTY = [0.0, 1.0, 0.0]


def _obs(**kw):
    # robot at (1, 2) heading +y; goal at (1, 2) + (-4, 0): 4 m away, 90 deg to its left
    base = dict(robot=0, tick=3, time_s=0.3, pose=np.array([1.0, 2.0, UP]),
                goal=np.array([-3.0, 2.0]), ranges_m=np.linspace(0.0, 3.0, BEAMS),
                angles_rad=np.linspace(-math.pi, math.pi, BEAMS, endpoint=False),
                safe_mask=np.array([1, 0, 1, 1, 0, 0, 1, 0], bool),
                y1=np.linspace(0.1, 0.8, BEAMS), message=None, inbox=())
    return RobotObservation(**{**base, **kw})


def test_ranges_observation_element_by_element():
    x = OBSERVATIONS["ranges"].build(_obs(), CFG)
    assert x.shape == (OBSERVATIONS["ranges"].size(CFG),) == (BEAMS + 3,)
    assert x[:BEAMS] == pytest.approx([i / 7 for i in range(8)])  # linspace(0, 3) / 3
    # goal 4 m away clipped to R: 1; bearing +90 deg: cos 0, sin 1
    assert x[BEAMS:] == pytest.approx([1.0, 0.0, 1.0], abs=1e-12)
    near = OBSERVATIONS["ranges"].build(_obs(goal=np.array([1.0 + 1.5, 2.0])), CFG)
    assert near[BEAMS:] == pytest.approx([0.5, 0.0, -1.0], abs=1e-12)  # 1.5 m, to the right


def test_safe_observation_element_by_element():
    x = OBSERVATIONS["safe"].build(_obs(), CFG)
    assert x.shape == (2 * BEAMS + 3,)
    assert x[:BEAMS].tolist() == [1, 0, 1, 1, 0, 0, 1, 0]
    assert x[BEAMS:2 * BEAMS] == pytest.approx(np.linspace(0.1, 0.8, BEAMS))
    assert x[-3:] == pytest.approx([1.0, 0.0, 1.0], abs=1e-12)
    with pytest.raises(FftnavError, match="observation 'safe' needs the FFT pipeline"):
        OBSERVATIONS["safe"].build(_obs(safe_mask=None, y1=None), CFG)


def _message(rows, minima):
    return encode_sigma(np.array(rows, float), is_min=np.array(minima), range_m=R)


def test_extrema_slots_keep_the_nearest_in_angle_order_and_pad():
    # ten extrema: angles -0.9 pi .. 0.9 pi, distances 3.0, 2.9, ... with two far ones (3 m)
    angles = np.linspace(-0.9, 0.9, 10) * math.pi
    dists = [3.0, 0.6, 1.2, 2.4, 3.0, 0.3, 0.9, 1.5, 1.8, 2.1]
    msg = _message(np.column_stack([angles, dists]), [i % 2 == 0 for i in range(10)])
    got = extrema_slots(msg, R).reshape(EXTREMA, 3)
    keep = [1, 2, 3, 5, 6, 7, 8, 9]  # every one but the two at 3 m, by increasing angle
    # the compact message quantises angles to 2 pi / 4096 and distances to R / 2047
    assert got[:, 0] == pytest.approx(angles[keep] / math.pi, abs=1 / 4096)
    assert got[:, 1] == pytest.approx(np.array(dists)[keep] / R, abs=1 / 2047)
    assert got[:, 2].tolist() == [-1, 1, -1, -1, 1, -1, 1, -1]
    few = extrema_slots(_message([[0.5, 1.5]], [False]), R).reshape(EXTREMA, 3)
    assert few[0] == pytest.approx([0.5 / math.pi, 0.5, -1], abs=1e-3)
    assert few[1:].tolist() == [EMPTY] * (EXTREMA - 1)
    assert extrema_slots(None, R).tolist() == EMPTY * EXTREMA
    assert extrema_slots(b"\x00\x01junk", R).tolist() == EMPTY * EXTREMA


def test_extrema_observation_is_the_own_message_then_the_goal():
    msg = _message([[-1.0, 0.75], [2.0, 3.0]], [True, False])
    x = OBSERVATIONS["extrema"].build(_obs(message=msg), CFG)
    assert x.shape == (3 * EXTREMA + 3,) == (OBSERVATIONS["extrema"].size(CFG),)
    assert x[:6] == pytest.approx([-1.0 / math.pi, 0.25, 1, 2.0 / math.pi, 1.0, -1], abs=1e-3)
    assert x[6:3 * EXTREMA].tolist() == EMPTY * (EXTREMA - 2)
    assert x[-3:] == pytest.approx([1.0, 0.0, 1.0], abs=1e-12)


def test_neighbours_observation_nearest_first_in_the_robots_frame():
    far = Packet(sender=4, tick=2, payload=_message([[0.0, 1.5]], [True]),
                 sender_pose=(1.0, 7.0, UP))  # 5 m ahead, same heading
    near = Packet(sender=2, tick=2, payload=_message([[math.pi / 2, 0.3]], [False]),
                  sender_pose=(-2.0, 2.0, math.pi))  # 3 m to the left, heading +90 deg from ours
    x = OBSERVATIONS["extrema+neighbours"].build(_obs(inbox=(far, near)), CFG)
    size = 3 * EXTREMA + 3 + NEIGHBOURS * (5 + 3 * EXTREMA)
    assert x.shape == (size,) == (OBSERVATIONS["extrema+neighbours"].size(CFG),)
    own = 3 * EXTREMA + 3
    slots = x[own:].reshape(NEIGHBOURS, 5 + 3 * EXTREMA)
    reach = CFG.comms.comm_range_m  # 6 m
    assert slots[0, :5] == pytest.approx([1, 0.0, 3 / reach, 0.0, 1.0], abs=1e-12)
    assert slots[0, 5:8] == pytest.approx([0.5, 0.1, -1], abs=1e-3)
    assert slots[1, :5] == pytest.approx([1, 5 / reach, 0.0, 1.0, 0.0], abs=1e-12)
    assert slots[1, 5:8] == pytest.approx([0.0, 0.5, 1], abs=1e-3)
    for empty in slots[2:]:
        assert empty[:5].tolist() == [0] * 5 and empty[5:].tolist() == EMPTY * EXTREMA
    # a sender beyond comm_range_m is clipped to the slot's bounds
    beyond = Packet(0, 2, b"", (1.0, 20.0, UP))
    x = OBSERVATIONS["extrema+neighbours"].build(_obs(inbox=(beyond,)), CFG)
    assert x[own:own + 5] == pytest.approx([1, 1.0, 0.0, 1.0, 0.0], abs=1e-12)


def _straight(n_in, observation="ranges"):
    # no weights, bias (1, 0): v = v_max, w = 0 whatever it sees
    return MLP(weights=[np.zeros((n_in, 2))], biases=[np.array([1.0, 0.0])],
               meta={"kind": "controller", "observation": observation, "version": 1})


def test_actions_are_clipped_outputs_scaled_to_the_limits(tmp_path):
    meta = {"kind": "controller", "observation": "ranges", "version": 1,
            "obs_mean": [0.5] * (BEAMS + 3), "obs_std": [2.0] * (BEAMS + 3)}
    w = np.zeros((BEAMS + 3, 2))
    w[0, 0], w[BEAMS + 2, 1] = 1.0, -1.0  # v from the first beam, w from the goal's sine
    MLP(weights=[w], biases=[np.array([0.2, 0.0])], meta=meta).save(tmp_path / "n.npz")
    ctrl = resolve(f"learned:{tmp_path / 'n.npz'}").make(
        ControllerSetup(1, CFG, np.random.default_rng(0)))
    action = ctrl.act(_obs())
    # first beam 0 / R -> (0 - 0.5) / 2 = -0.25, + 0.2 = -0.05; sine 1 -> -(1 - 0.5) / 2
    assert action.v_mps == pytest.approx(-0.05 * CFG.robot.v_max_mps)
    assert action.w_radps == pytest.approx(-0.25 * CFG.robot.w_max_radps)
    assert action.message is None
    big = ctrl.commands(np.full((1, BEAMS + 3), 100.0))  # outputs beyond 1 are clipped
    assert big[0].tolist() == [CFG.robot.v_max_mps, -CFG.robot.w_max_radps]


def _world(starts, goals, size=(6.0, 8.0)):
    return World("test", 0, size, (), np.array(starts, float), np.array(goals, float))


def test_a_straight_net_drives_the_predicted_trajectory(tmp_path):
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=8.0))
    _straight(cfg.sensor.beams + 3).save(tmp_path / "straight.npz")
    result = run_episode(_world([[1, 1, UP]], [[1, 4.02]]),
                         f"learned:{tmp_path / 'straight.npz'}", seed=0, config=cfg)
    (row,) = result.rows
    assert row.policy == "learned-straight" and row.arrived and not row.collided
    v, dt = cfg.robot.v_max_mps, 1.0 / cfg.episode.control_hz
    path = result.trajectories[0]
    ticks = np.arange(len(path))
    assert path[:, 0] == pytest.approx(1.0, abs=1e-6)  # straight up: x and yaw never change
    assert path[:, 2] == pytest.approx(UP, abs=1e-6)
    assert path[:, 1] == pytest.approx(1.0 + v * dt * ticks, abs=1e-6)
    # it stops on entering the success radius: after 3.02 m - 0.3 m at 0.05 m a tick, the
    # first tick past 54.4
    assert len(path) == 56 and row.time_s == pytest.approx(55 * dt)
    assert row.path_length_m == pytest.approx(55 * v * dt)


@pytest.mark.parametrize("observation", list(OBSERVATIONS))
def test_an_untrained_net_runs_an_episode_with_every_observation(tmp_path, observation):
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=2.0),
                      comms=CommsConfig(broadcast="every_tick"))
    untrained(observation, seed=1, hidden=(16,)).save(tmp_path / "u.npz")
    world = _world([[1, 1, UP], [3, 1, UP]], [[1, 7], [3, 7]])
    rows = run_episode(world, f"learned:{tmp_path / 'u.npz'}", seed=0, config=cfg).rows
    assert [r.policy for r in rows] == ["learned-u", "learned-u"]
    assert all(r.path_length_m > 0 for r in rows)
    talks = OBSERVATIONS[observation].messages
    assert all((r.messages_sent > 0) == talks for r in rows)


def test_untrained_is_deterministic_and_glorot_bounded():
    a, b = untrained("ranges", seed=5), untrained("ranges", seed=5)
    assert a == b and a != untrained("ranges", seed=6)
    assert a.sizes == (363, 64, 64, 2) and a.output == "tanh"
    assert np.abs(a.weights[0]).max() <= math.sqrt(6 / (363 + 64))
    assert all((b == 0).all() for b in a.biases)
    small = untrained("ranges", seed=0, hidden=(), config=CFG)
    assert small.sizes == (BEAMS + 3, 2)
    with pytest.raises(FftnavError, match=r"observation must be a registered observation"):
        untrained("lidar", seed=0)
    with pytest.raises(FftnavError, match=r"seed must be an integer >= 0, got seed=-1"):
        untrained("ranges", seed=-1)
    with pytest.raises(FftnavError, match=r"hidden must be integers >= 1, got hidden=\(0,\)"):
        untrained("ranges", seed=0, hidden=(0,))


def _save(tmp_path, name, **meta):
    net = MLP(weights=[np.zeros((BEAMS + 3, meta.pop("n_out", 2)))],
              biases=[np.zeros(meta.pop("n_bias", 2))],
              meta={"kind": "controller", "observation": "ranges", "version": 1, **meta})
    return net.save(tmp_path / name)


@pytest.mark.parametrize(("meta", "match"), [
    ({"kind": "decider"}, r"meta\['kind'\] must be 'controller' for a learned controller, "
                          r"got kind='decider'"),
    ({"observation": "lidar"}, r"meta\['observation'\] must be one of ranges, safe, extrema, "
                               r"extrema\+neighbours, got observation='lidar'"),
    ({"n_out": 3, "n_bias": 3}, r"the network must have 2 outputs \(v, w\), got n_out=3"),
    ({"obs_mean": [0.0] * (BEAMS + 3)}, r"meta must hold both obs_mean and obs_std, or neither"),
    ({"obs_mean": [0.0] * 3, "obs_std": [1.0] * 3}, r"meta\['obs_mean'\] must be 11 finite"),
    ({"obs_mean": [0.0] * 11, "obs_std": [0.0] * 11}, r"meta\['obs_std'\] must be 11 finite "
                                                      r"numbers > 0"),
])
def test_bad_controller_files_are_refused_naming_the_file(tmp_path, meta, match):
    path = _save(tmp_path, "bad.npz", **meta)
    with pytest.raises(FftnavError, match=match) as err:
        resolve(f"learned:{path}")
    assert str(path) in str(err.value)


def test_an_input_size_other_than_the_configs_is_refused_naming_the_file(tmp_path):
    path = _save(tmp_path, "eight.npz")  # made for 8 beams
    found = resolve(f"learned:{path}")
    with pytest.raises(FftnavError, match=r"eight\.npz: the network takes 11 inputs, the "
                                          r"observation 'ranges' has 363 with sensor\.beams=360"):
        found.make(ControllerSetup(1, SwarmConfig(), np.random.default_rng(0)))


def test_missing_file_and_empty_path_are_refused(tmp_path):
    with pytest.raises(FftnavError, match=r"nope\.npz: no such file"):
        resolve(f"learned:{tmp_path / 'nope.npz'}")
    with pytest.raises(FftnavError, match=r"must be named learned:PATH\.npz, got 'learned:'"):
        resolve("learned:")


def test_learned_prefix_takes_precedence_over_module_attr(tmp_path, monkeypatch):
    # 'learned:w.npz' also has the form module:attr (module 'learned', attribute 'w.npz')
    monkeypatch.chdir(tmp_path)
    _save(tmp_path, "w.npz")
    found = resolve("learned:w.npz")
    assert found.name == "learned-w" and found.file == tmp_path / "w.npz"
    assert found.controller is not None and found.plugin
    assert resolve("vfh").name == "vfh" and resolve("fftnav.navigation.baselines:VFHController")
    odd = _save(tmp_path, "my net (v2).npz")
    assert resolve(f"learned:{odd}").name == "learned-my_net__v2_"


def test_the_weights_hash_enters_config_json(tmp_path):
    path = _save(tmp_path, "w.npz")
    data = {"experiment": {"name": "t", "envs": ["forest"], "maps": 1, "map_seed": 0, "robots": 2,
                           "policies": [f"learned:{path}"]},
            "sensor": {"beams": BEAMS}}
    before = json.loads(canonical_config(parse_config(data), ("robot",)))
    digest = before["plugin_sha256"][str(path)]
    assert digest == __import__("hashlib").sha256(path.read_bytes()).hexdigest()


def test_trained_networks_in_a_config_are_taken_from_its_folder(tmp_path):
    """``learned:`` and ``learned-decider:`` paths in ``policies`` are relative to the config's
    folder, as plugin files are, and resolve to the controller and the decision policy."""
    from fftnav.navigation.learned_decider import untrained_decider
    from fftnav.runner import parse_config

    (tmp_path / "nets").mkdir()
    untrained("extrema", seed=1).save(tmp_path / "nets" / "c.npz")
    untrained_decider(2).save(tmp_path / "nets" / "d.npz")
    config = parse_config({"experiment": {
        "name": "t", "envs": ["forest"], "maps": 1, "map_seed": 7, "robots": 3,
        "policies": ["learned:nets/c.npz", "learned-decider:nets/d.npz"]}}, base=tmp_path)
    assert config.policies == (f"learned:{tmp_path / 'nets' / 'c.npz'}",
                               f"learned-decider:{tmp_path / 'nets' / 'd.npz'}")
    found = config.resolved
    assert list(found) == ["learned-c", "learned-decider-d"]
    assert found["learned-c"].controller is not None and found["learned-c"].policy is None
    assert found["learned-decider-d"].policy is not None


def test_a_network_retrained_under_the_same_path_is_read_again(tmp_path):
    path = tmp_path / "net.npz"
    untrained("extrema", seed=1).save(path)
    first = resolve(f"learned:{path}").controller.net
    untrained("extrema", seed=2).save(path)
    second = resolve(f"learned:{path}").controller.net
    assert first == untrained("extrema", seed=1) and second == untrained("extrema", seed=2)
