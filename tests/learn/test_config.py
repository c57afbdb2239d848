"""The training TOML of fftnav learn: defaults, and every bad value refused naming its key."""

from __future__ import annotations

import pytest

from fftnav.errors import FftnavError
from fftnav.learn import load_learn_config, parse_learn_config

BASE = {"learn": {"observation": "extrema"}, "train": {"map_seeds": [5000, 6000]},
        "validation": {"map_seeds": [7000, 7100]}}


def _with(section, **values):
    data = {k: dict(v) for k, v in BASE.items()}
    data.setdefault(section, {}).update(values)
    return data


def test_defaults():
    c = parse_learn_config(BASE)
    assert (c.method, c.observation, c.seed, c.hidden, c.robots) == ("controller", "extrema", 0,
                                                                    (64, 64), 15)
    assert c.v_range == (-1.0, 1.0) and c.min_live == 0.0
    assert c.train.worlds == ("forest",) and (c.train.first, c.train.end) == (5000, 6000)
    assert c.validate_every == 100_000 and c.validate_episodes == 4
    assert c.swarm.robot.v_max_mps == 0.5


def test_a_decider_needs_no_observation_and_refuses_one():
    c = parse_learn_config({**BASE, "learn": {"method": "decider"}})
    assert c.method == "decider" and c.observation is None
    with pytest.raises(FftnavError, match=r"learn.observation is for a controller"):
        parse_learn_config({**BASE, "learn": {"method": "decider", "observation": "ranges"}})


def test_the_budget_may_grow_on_resume_but_nothing_else():
    a = parse_learn_config(BASE)
    b = parse_learn_config(_with("learn", agent_steps=5))
    c = parse_learn_config(_with("ppo", learning_rate=1e-3))
    assert a.sha256() == b.sha256() != c.sha256()


@pytest.mark.parametrize("data, match", [
    (_with("learn", observation="lidar"), r"learn.observation must be one of .*got learn.observation='lidar'"),
    ({**BASE, "learn": {}}, r"learn.observation is required for a controller"),
    (_with("learn", method="planner"), r"learn.method must be one of"),
    (_with("learn", seed=-1), r"learn.seed must be an integer >= 0, got learn.seed=-1"),
    (_with("learn", agent_steps=0), r"learn.agent_steps must be an integer >= 1"),
    (_with("learn", hidden=[]), r"learn.hidden must be a non-empty list"),
    (_with("learn", hidden=[64, 0]), r"learn.hidden must be an integer in \[1, 4096\]"),
    (_with("learn", lr=1), r"unknown key learn.lr"),
    (_with("ppo", n_epochs=0), r"ppo.n_epochs must be an integer >= 1"),
    (_with("ppo", gamma=1.5), r"ppo.gamma must be a finite number in \[0, 1\]"),
    (_with("ppo", foo=1), r"unknown key ppo.foo"),
    (_with("action", kind="discrete"), r"action.kind must be one of \['continuous'\]"),
    (_with("action", v_range=[0.5, 0.2]), r"action.v_range must be \[lo, hi\]"),
    (_with("train", map_seeds=[990, 1001]), r"train.map_seeds=\[990, 1001\] overlaps Table I"),
    (_with("validation", map_seeds=[1019, 1030]), r"validation.map_seeds=\[1019, 1030\] overlaps"),
    (_with("validation", map_seeds=[5500, 5600]), r"and validation.map_seeds=\[5500, 5600\] overlap"),
    (_with("train", map_seeds=[5000]), r"train.map_seeds must be \[first, end\)"),
    (_with("train", map_seeds=[6000, 5000]), r"train.map_seeds\[1\] must be an integer >= 6001"),
    (_with("train", worlds=["moon"]), r"train.worlds must be one of"),
    (_with("train", min_live=2), r"train.min_live must be a finite number in \[0, 1\]"),
    (_with("validation", episodes=500), r"validation.episodes must be an integer in \[1, 100\]"),
    (_with("sensor", range_m=-1), r"range_m"),
    ({**BASE, "trainer": {}}, r"unknown section \[trainer\]"),
    ({**BASE, "train": {"worlds": ["forest"]}}, r"train.map_seeds is required"),
])
def test_bad_values_are_refused_naming_the_key(data, match):
    with pytest.raises(ValueError, match=match):
        parse_learn_config(data)


def test_a_file_error_names_the_file(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text('[learn]\nobservation = "extrema"\n[train]\nmap_seeds = [1, 2]\n')
    with pytest.raises(FftnavError, match=r"t.toml: validation.map_seeds is required"):
        load_learn_config(path)
    path.write_text("[learn\n")
    with pytest.raises(FftnavError, match=r"t.toml"):
        load_learn_config(path)


def test_the_reference_configs_parse():
    from pathlib import Path

    folder = Path(__file__).parents[2] / "experiments" / "learn"
    configs = sorted(folder.glob("*.toml"))
    assert configs, folder
    for path in configs:
        c = load_learn_config(path)
        for rng in (c.train, c.validation):
            assert not rng.overlaps((1000, 1020))
