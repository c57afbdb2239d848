"""Suites: every shipped suite is what its version pins, a changed default is caught and
named, names resolve (families to their newest version), reference rows are checked."""

from __future__ import annotations

import functools
import json

import pytest

import fftnav.suites as suites
from fftnav.config import PlannerConfig, SensorConfig
from fftnav.suites import SUITES, ReferenceError, find_suite, read_references, resolve_suites

SHIPPED = sorted(SUITES)


@pytest.mark.parametrize("name", SHIPPED)
def test_each_shipped_suite_is_what_its_version_pins(name):
    """Fails when a default a suite depends on (a world preset, a robot, sensor, comms,
    episode, planner or localization setting, the map generator, the episode seeds, the
    episode columns) changed without a new version of the suite."""
    assert SUITES[name].changes() == [], (
        f"{name} no longer resolves to its pins: give it a new version and new references")


def test_the_shipped_suites_are_paper_walls_traps_and_all():
    assert {"paper-v2", "walls-v1", "traps-v1", "all-v1"} <= set(SUITES)
    assert [p.name for p in SUITES["all-v1"].parts] == ["paper-v2", "walls-v1", "traps-v1"]


def _default(cls, monkeypatch, **defaults):
    """Make the dataclass ``cls`` default ``defaults`` (what a changed default looks like)."""
    monkeypatch.setattr(cls, "__init__", functools.partialmethod(cls.__init__, **defaults))


@pytest.mark.parametrize(("cls", "key", "value", "named"), [
    (SensorConfig, "range_m", 4.0, "swarm.sensor.range_m: pinned 3.0 -> 4.0"),
    (PlannerConfig, "heading_tol_deg", 25.0,
     "swarm.planner.heading_tol_deg: pinned 20.0 -> 25.0"),
])
def test_a_changed_default_is_named_and_refused(monkeypatch, cls, key, value, named):
    suite = SUITES["paper-v2"]
    _default(cls, monkeypatch, **{key: value})
    assert named in suite.changes()
    with pytest.raises(ValueError, match=r"suite paper-v2 is not what its version pins: .*"
                       + key + r".*a new version of the suite is needed"):
        suite.check()


def test_a_changed_world_preset_changes_the_parameters_and_the_maps(monkeypatch):
    from fftnav.world import generate

    real = generate.load_preset

    def denser(env):
        params = dict(real(env))
        if env == "walls":
            params["wall_length_m"] = [4.0, 5.0]
        return params

    monkeypatch.setattr(generate, "load_preset", denser)
    changes = SUITES["walls-v1"].changes()
    assert any(c.startswith("world.walls.wall_length_m: pinned") for c in changes)
    assert any(c.startswith("worlds_sha256.walls: pinned") for c in changes)


def test_families_resolve_to_their_newest_version(tiny, monkeypatch):
    newer = suites.Suite("tiny", 3, "d", "m", tables=tiny.tables)
    monkeypatch.setitem(SUITES, newer.name, newer)
    assert find_suite("tiny").name == "tiny-v3"
    assert find_suite("tiny-v1").name == "tiny-v1"
    assert find_suite("all").name == "all-v1"
    assert [s.name for s in resolve_suites(["paper", "paper-v2", "all"])] == ["paper-v2",
                                                                              "all-v1"]


def test_an_unknown_suite_is_refused_with_the_known_names():
    with pytest.raises(ValueError, match=r"suite must be a registered suite \(.*'paper-v2'.*\), "
                       r"got suite='papr-v2'; did you mean 'paper-v2'\?"):
        find_suite("papr-v2")


def test_a_suite_definition_must_be_complete_and_well_named():
    with pytest.raises(ValueError, match=r"needs a \[suite\] table"):
        suites.suite_from_toml("[experiment]\nmaps = 1\n")
    with pytest.raises(ValueError, match=r"lacks suite.measures"):
        suites.suite_from_toml('[suite]\nfamily = "x"\nversion = 1\ndescription = "d"\n')
    text = '[suite]\nfamily = "x"\nversion = 2\ndescription = "d"\nmeasures = "m"\n'
    with pytest.raises(ValueError, match=r"suite file x-v1.toml must be named x-v2.toml"):
        suites.suite_from_toml(text, file="x-v1.toml")


@pytest.mark.parametrize("name", [n for n in SHIPPED if not SUITES[n].includes])
def test_shipped_references_cover_every_map_of_every_builtin_once(name):
    suite = SUITES[name]
    episodes, timing = read_references(suite)
    config = suite.experiment(["bug-left"])
    maps = {(e, config.map_seed + i) for e in config.envs for i in range(config.maps)}
    assert set(episodes["policy"]) == set(suites.builtin_methods())
    for _, rows in episodes.groupby("policy"):
        assert set(zip(rows["env"], rows["map_seed"], strict=True)) == maps
        assert len(rows) == len(maps) * config.robots
    assert len(timing) == len(maps) * len(suites.builtin_methods())


def test_a_tampered_reference_row_is_detected(tiny):
    folder = suites.references_folder(tiny.name)
    path = folder / "fusion.csv"
    lines = path.read_text().splitlines()
    fields = lines[3].split(",")
    spl = fields.index(next(f for f in fields[10:12] if "." in f))
    fields[spl] = "0.999999"
    lines[3] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ReferenceError, match=r"fusion.csv does not match its checksum in "
                       r"SHA256SUMS: it was changed after it was made"):
        read_references(tiny)


def test_missing_references_are_refused(tiny):
    (suites.references_folder(tiny.name) / "SHA256SUMS").unlink()
    with pytest.raises(ReferenceError, match=r"no reference rows in .*tiny-v1 \(no SHA256SUMS\)"):
        read_references(tiny)


def test_the_pins_hold_every_setting_resolved(tiny):
    pins = json.loads(suites.pins_path(tiny.name).read_text())
    assert pins["swarm"]["sensor"]["range_m"] == 3.0  # a default, written out
    assert pins["world"]["forest"]["size_m"] == [8.0, 8.0]  # the suite's override
    assert len(pins["episode_seeds"]["forest"]) == 2
    assert set(pins["swarm"]) >= {"robot", "sensor", "comms", "episode", "planner",
                                  "localization"}


def test_a_reference_episode_is_rerun_recorded_and_checked(tiny):
    rerun = suites.rerun_task(tiny, "forest-8-fusion")
    assert rerun.task.task_id == "forest-8-fusion"
    assert rerun.result.recording  # recorded, for the replay
    assert len(rerun.recording().rows) == 3
    with pytest.raises(ValueError, match=r"task must be a reference episode of tiny-v1 "
                       r"\(ENV-MAP_SEED-METHOD of a built-in\), got task='forest-8-fusoin'; "
                       r"did you mean forest-8-fusion"):
        suites.rerun_task(tiny, "forest-8-fusoin")
    episodes, timing = read_references(tiny)
    episodes.loc[episodes["policy"] == "fusion", "time_s"] += 1.0
    suites.write_references(tiny, episodes, timing, suites.references_folder(tiny.name))
    with pytest.raises(ValueError, match=r"the rerun of forest-8-fusion must give the shipped "
                       r"reference rows of tiny-v1, got other rows \(robot 0: time_s"):
        suites.rerun_task(tiny, "forest-8-fusion")
