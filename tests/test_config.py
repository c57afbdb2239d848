"""The episode section's limits: the physics-step limit checked once, against the real time
limit and the last departure; at least one control tick; no overflow from huge delays."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from fftnav.config import EpisodeConfig, SwarmConfig
from fftnav.limits import MAX_EPISODE_PHYSICS_STEPS
from fftnav.sim.swarm import SimConfig


def test_fast_physics_within_the_step_limit_is_accepted_by_config_and_simulator():
    cfg = SwarmConfig().replace({"physics_hz": "2e5", "time_limit_s": "10"})
    assert cfg.episode.time_limit_s * cfg.episode.physics_hz == 2e6 < MAX_EPISODE_PHYSICS_STEPS
    assert SimConfig.for_swarm(cfg).substeps == 20_000
    from fftnav.runner import parse_config

    experiment = parse_config({"experiment": {"name": "fast", "envs": ["forest"], "maps": 1,
                                              "map_seed": 0, "robots": 15,
                                              "policies": ["fusion"]},
                               "episode": {"physics_hz": 2e5, "time_limit_s": 10}})
    assert experiment.swarm == cfg
    with pytest.raises(ValueError, match=r"physics steps per episode \(time_limit_s x "
                                         r"physics_hz\): 1,000,000,000 estimated"):
        SwarmConfig().replace({"physics_hz": "1e7", "time_limit_s": "100"})
    # 1e8 steps: about 80 minutes of physics for 15 robots, refused before any work
    with pytest.raises(ValueError, match=r"100,000,000 estimated, above the limit of 3,000,000; "
                                         r"lower time_limit_s or physics_hz"):
        SwarmConfig().replace({"physics_hz": "1e7", "time_limit_s": "10"})


def test_at_least_one_control_tick_within_the_time_limit():
    with pytest.raises(ValueError, match=r"control_hz must give at least one control tick "
                                         r"within time_limit_s=120\.0 .*got control_hz=1e-06"):
        EpisodeConfig(control_hz=1e-6)
    with pytest.raises(ValueError, match="at least one control tick"):
        EpisodeConfig(control_hz=0.1, physics_hz=240, time_limit_s=4.9)  # rounds to 0 ticks
    assert EpisodeConfig(control_hz=0.1, physics_hz=240, time_limit_s=6).max_ticks == 1


@pytest.mark.parametrize(("departure", "key"), [("staggered", "stagger_s"),
                                                ("waves", "wave_interval_s")])
def test_huge_departure_delays_are_refused_naming_the_key(departure, key):
    with pytest.raises(ValueError, match=rf"\(last departure \+ time_limit_s\) x physics_hz, "
                                         rf"2 robots .*2\.4e\+302 estimated, above the limit "
                                         rf"of 3,000,000; lower {key}"):
        SwarmConfig().replace({"departure": departure, key: "1e300"})
    # a delay that only matters with departure = together is harmless
    assert SwarmConfig().replace({key: "1e300"}).episode.departure_ticks(15) == [0] * 15


def test_the_last_departure_is_checked_for_the_robots_there_are():
    ep = EpisodeConfig(departure="staggered", stagger_s=1e4)  # fits two robots
    assert ep.departure_ticks(2) == [0, 100_000]
    with pytest.raises(ValueError, match=r"3 robots staggered by stagger_s=10000\.0\): "
                                         r"4,828,800 estimated"):  # (1,200 + 200,000) x 24
        ep.departure_ticks(3)
    waves = EpisodeConfig(departure="waves", waves=3, wave_interval_s=1e4)
    assert waves.last_departure_s(2) == 1e4 and waves.last_departure_s(15) == 2e4
    with pytest.raises(ValueError, match=r"lower wave_interval_s"):
        waves.check_departures(15)


def _world(tmp_path):
    from fftnav.world import generate_world, save_world

    world = tmp_path / "w.json"
    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=3), world)
    return world


def test_fftnav_episode_with_two_beams_prints_no_warning(tmp_path):
    """Two beams make one-tap filters, whose -3 dB point is Nyquist: the episode runs and its
    stderr is the outcome line alone."""
    proc = subprocess.run([sys.executable, "-m", "fftnav", "episode", "--world",
                           str(_world(tmp_path)), "--policy", "fusion", "--set", "beams=2",
                           "--set", "time_limit_s=1", "--out", str(tmp_path / "e.csv")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("\n") == 1 and "/3 arrived" in proc.stderr, proc.stderr


def test_fftnav_episode_refuses_huge_delays_before_the_episode(tmp_path):
    world = _world(tmp_path)
    for sets, match in ((["stagger_s=1e300"], "2 robots staggered by stagger_s=1e+300"),
                        (["stagger_s=1e4"], "3 robots staggered by stagger_s=10000.0"),
                        (["control_hz=1e-6"], "at least one control tick")):
        argv = ["episode", "--world", str(world), "--policy", "fusion",
                "--set", "departure=staggered", *(a for s in sets for a in ("--set", s))]
        proc = subprocess.run([sys.executable, "-m", "fftnav", *argv], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 2 and proc.stdout == "", proc.stderr
        assert proc.stderr.startswith("fftnav episode: error: ") and match in proc.stderr
        assert proc.stderr.count("\n") == 1, proc.stderr


def test_the_planner_section_sets_the_planners_constants():
    """``[planner]`` reaches the planner of every policy: at 10 degrees of tolerance a heading
    error of 5 degrees is driven straight, at 3 degrees it is turned in place, and with the
    default (steered, 20 degrees) it is turned while driving."""
    from fftnav.navigation.bug import BugPlanner

    def command(config):
        planner = BugPlanner.for_swarm(1, config, lambda i: 1)
        return planner._command(math.radians(5.0))

    narrow = SwarmConfig.from_sections({"planner": {"heading_tol_deg": 3}})
    wide = SwarmConfig.from_sections({"planner": {"heading_tol_deg": 10, "replan_s": 2,
                                                  "drive": "straight"}})
    assert wide.planner.heading_tol_deg == 10.0 and wide.planner.replan_s == 2.0
    assert command(narrow) == (0.0, pytest.approx(math.radians(5.0) * 10.0))
    assert command(wide) == (narrow.robot.v_max_mps, 0.0)
    assert command(SwarmConfig()) == (0.5, pytest.approx(math.radians(5.0) * 10.0))  # steered
    params = BugPlanner.for_swarm(1, wide, lambda i: 1).params
    assert params.replan_s == 2.0 and params.heading_tol_rad == pytest.approx(math.radians(10))
    assert SwarmConfig().replace({"heading_tol_deg": "20"}).planner.heading_tol_deg == 20.0


@pytest.mark.parametrize(("table", "message"), [
    ({"heading_tol_deg": 0}, r"planner\.heading_tol_deg must be a finite number in \(0, 90\], "
                             r"got planner\.heading_tol_deg=0"),
    ({"map_every": 1.5}, r"planner\.map_every must be an integer >= 1, got planner\.map_every=1\.5"),
    ({"map_squeeze_m": 0.4}, r"map_squeeze_m must be <= map_clearance_m=0\.3, "
                             r"got map_squeeze_m=0\.4"),
    ({"drive": "arc"}, r"planner\.drive must be one of \['straight', 'steered'\], "
                       r"got planner\.drive='arc'"),
    ({"heading_tol": 10}, r"unknown key planner\.heading_tol; expected one of \['heading_tol_deg'"),
])
def test_bad_planner_constants_are_refused_naming_the_key(table, message):
    with pytest.raises(ValueError, match=message):
        SwarmConfig.from_sections({"planner": table})


def test_fftnav_episode_refuses_a_bad_planner_constant_in_one_line(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "fftnav", "episode", "--world",
                           str(_world(tmp_path)), "--policy", "fusion",
                           "--set", "planner.heading_tol_deg=120"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == "", proc.stderr
    assert proc.stderr.count("\n") == 1 and "planner.heading_tol_deg must be" in proc.stderr
