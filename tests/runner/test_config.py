"""Experiment configs: validation with pinned messages, the shipped configs, task seeds."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import pytest

from fftnav.config import EpisodeConfig, SensorConfig, SwarmConfig
from fftnav.runner import load_config, make_tasks, parse_config

ROOT = Path(__file__).resolve().parents[2]

BASE = {
    "experiment": {"name": "t", "envs": ["forest", "rocky"], "maps": 3, "map_seed": 10,
                   "robots": 4, "policies": ["bug-left", "fusion"]},
    "sensor": {"beams": 180},
    "episode": {"time_limit_s": 30},
}


def with_value(path: str, value: object) -> dict:
    data = copy.deepcopy(BASE)
    section, key = path.split(".")
    data.setdefault(section, {})[key] = value
    return data


def test_valid_config_maps_sections_to_episode_config():
    config = parse_config(BASE)
    assert config.envs == ("forest", "rocky") and config.maps == 3 and config.robots == 4
    assert config.swarm == SwarmConfig(sensor=SensorConfig(beams=180),
                                       episode=EpisodeConfig(time_limit_s=30.0))
    assert isinstance(config.swarm.episode.time_limit_s, float)
    assert config.out == "results/t" and config.trajectory_maps == 1


@pytest.mark.parametrize("path, value, match", [
    ("experiment.maps", 0, r"experiment\.maps must be an integer >= 1, got experiment\.maps=0"),
    ("experiment.maps", 2.5, r"experiment\.maps must be an integer >= 1, got experiment\.maps=2\.5"),
    ("experiment.robots", "3", r"experiment\.robots must be an integer >= 1, got experiment\.robots='3'"),
    ("experiment.map_seed", -1, r"experiment\.map_seed must be an integer >= 0, got experiment\.map_seed=-1"),
    ("experiment.maps", True, r"experiment\.maps must be an integer >= 1, got experiment\.maps=True"),
    ("experiment.trajectory_maps", 4,
     r"\[experiment\] trajectory_maps must be <= maps=3, got trajectory_maps=4"),
    ("experiment.policies", ["fusion", "teleport"],
     r"experiment\.policies: policy must be a registered policy or controller \('bug-left', "
     r".*\) or module:attr or path/to/file\.py:attr, got policy='teleport'$"),
    ("experiment.policies", ["fusion", "fusion"],
     r"experiment\.policies must be a non-empty list of distinct strings"),
    ("experiment.envs", [], r"experiment\.envs must be a non-empty list"),
    ("experiment.envs", ["moon"],
     r"experiment\.envs: env must be a registered world kind \('forest', .*\) or a world file, "
     r"got env='moon'$"),
    ("experiment.envs", ["forst"], r"got env='forst'; did you mean 'forest'\?$"),
    ("experiment.name", "a b", r"experiment\.name must be a non-empty string"),
    ("experiment.out", "", r"experiment\.out must be a non-empty string, got experiment\.out=''"),
    ("experiment.colour", 1, r"unknown key experiment\.colour; expected one of"),
    ("robot.wheels", 2, r"unknown key robot\.wheels; expected one of"),
    ("sensor.beams", 90.5, r"sensor\.beams must be an integer in \[2, 100000\], got sensor\.beams=90\.5"),
    ("sensor.range_m", "far", r"sensor\.range_m must be a finite number in \(0, 1000\], got sensor\.range_m='far'"),
    ("sensor.range_m", float("nan"), r"sensor\.range_m must be a finite number in \(0, 1000\], got sensor\.range_m=nan"),
    ("comms.packet_loss", -0.1, r"comms\.packet_loss must be a finite number in \[0, 1\), got comms\.packet_loss=-0\.1"),
    ("comms.broadcast", 1, r"comms\.broadcast must be one of \['on_obstacle', 'every_tick'\], got comms\.broadcast=1"),
    ("sensor.dropout", 1.5, r"sensor\.dropout must be a finite number in \[0, 1\), got sensor\.dropout=1\.5"),
    ("world.robots", 4, r"world\.robots cannot be overridden; it is set by the experiment"),
    ("world.density_per_m2", -1.0,
     r"\[world\] for env 'forest': density_per_m2 must be a finite number in \[0, 1\], got density_per_m2=-1\.0"),
    ("world.size_m", "big",
     r"\[world\] for env 'forest': size_m must be a list of 2 numbers, got size_m='big'"),
    ("world.density", 0.1, r"unknown key world\.density; expected one of"),
    ("robot.r_m", 0.1, r"\[robot\] r_m must be > r0_m=0\.15, got r_m=0\.1"),
    ("episode.physics_hz", 25.0, r"\[episode\] physics_hz must be an integer multiple of "
     r"control_hz=10\.0, got physics_hz=25\.0"),
])
def test_invalid_value_or_unknown_key_is_refused_naming_the_key(path, value, match):
    with pytest.raises(ValueError, match=match):
        parse_config(with_value(path, value))


def test_an_experiment_config_checks_its_fields_when_made():
    config = parse_config(BASE)
    assert (config.name, config.maps, config.map_seed, config.robots) == ("t", 3, 10, 4)
    with pytest.raises(ValueError, match=r"maps must be an integer >= 1, got maps=0"):
        dataclasses.replace(config, maps=0)
    with pytest.raises(ValueError, match=r"trajectory_maps must be <= maps=3, "
                                         r"got trajectory_maps=5"):
        dataclasses.replace(config, trajectory_maps=5)
    with pytest.raises(ValueError, match=r"name must be a non-empty string of letters, digits, "
                                         r"'_', '\.', '-', got name='a/b'"):
        dataclasses.replace(config, name="a/b")


def test_unknown_section_missing_key_and_world_table_of_other_env():
    with pytest.raises(ValueError, match=r"unknown section \[physics\]"):
        parse_config({**BASE, "physics": {}})
    data = copy.deepcopy(BASE)
    del data["experiment"]["robots"]
    with pytest.raises(ValueError, match=r"experiment\.robots is required"):
        parse_config(data)
    data = copy.deepcopy(BASE)
    data["experiment"]["envs"] = ["forest"]
    data["world"] = {"rocky": {}}
    with pytest.raises(ValueError, match=r"world\.rocky is not one of experiment\.envs"):
        parse_config(data)


def test_invalid_toml_names_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[experiment\nname = 1\n")
    with pytest.raises(ValueError, match=r"bad\.toml: invalid TOML"):
        load_config(path)


@pytest.mark.parametrize("name", ["table1", "smoke", "forest5"])
def test_shipped_configs_are_valid(name):
    config = load_config(ROOT / "experiments" / f"{name}.toml")
    assert config.name == name
    if name == "table1":  # the paper's setup (Sec. IV)
        assert config.envs == ("forest", "rocky") and config.maps == 20 and config.robots == 15
        assert {"bug-left", "bug-right", "fusion"} <= set(config.policies)


def test_tasks_pair_policies_on_the_same_map_and_episode_seed():
    config = parse_config(BASE)
    tasks = make_tasks(config)
    assert len(tasks) == 2 * 3 * 2 and tasks == sorted(tasks)
    seeds = {(t.env, t.map_seed): set() for t in tasks}
    for t in tasks:
        seeds[(t.env, t.map_seed)].add(t.episode_seed)
    assert all(len(s) == 1 for s in seeds.values())  # paired across policies
    assert len({s.pop() for s in seeds.values()}) == 6  # distinct across maps and envs
    assert {t.map_seed for t in tasks} == {10, 11, 12}
    assert [t.keep_trajectories for t in tasks if t.env == "forest"] == [True] * 2 + [False] * 4
    # an env's episode seeds do not depend on which other envs the experiment has
    alone = parse_config(with_value("experiment.envs", ["rocky"]))
    assert [t for t in make_tasks(alone)] == [t for t in tasks if t.env == "rocky"]
