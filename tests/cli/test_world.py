"""``fftnav world ...`` run as subprocesses (``fftnav bench sim``: tests/test_sim_bench.py)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from fftnav.optimal.difficulty import MEASURES, map_difficulty
from fftnav.world import World, load_world, save_world
from fftnav.world.obstacles import rectangle
from tests.sim.lidar_oracle import assert_ranges_match_analytic


def _run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


@pytest.fixture(scope="module")
def world_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("w") / "forest.json"
    res = _run("world", "generate", "--env", "forest", "--seed", "3", "--size", "12", "14",
               "--density", "0.1", "--robots", "6", "--out", str(path))
    assert res.returncode == 0, res.stderr
    return path


def test_generate_writes_the_documented_json(world_file):
    data = json.loads(world_file.read_text())
    assert set(data) == {"env", "seed", "size", "obstacles", "starts", "goals"}
    assert data["size"] == [12.0, 14.0] and len(data["obstacles"]) == round(0.1 * 12 * 14)
    assert len(data["starts"]) == len(data["goals"]) == 6
    assert {o["shape"] for o in data["obstacles"]} == {"circle"}


def test_generate_walls_and_traps_and_the_boundary_option(tmp_path):
    for env, boundary in (("walls", None), ("traps", "open"), ("forest", "walls")):
        path = tmp_path / f"{env}.json"
        extra = ["--boundary", boundary] if boundary else []
        res = _run("world", "generate", "--env", env, "--seed", "2", "--out", str(path), *extra)
        assert res.returncode == 0, res.stderr
        assert json.loads(path.read_text()).get("boundary", "open") == (boundary or "walls")
    res = _run("world", "generate", "--env", "walls", "--seed", "2", "--boundary", "fence",
               "--out", str(tmp_path / "x.json"))
    assert res.returncode == 2 and "invalid choice: 'fence'" in res.stderr


def test_render_grid_and_ros_map(world_file, tmp_path):
    res = _run("world", "render", str(world_file), "--out", str(tmp_path / "w.png"))
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "w.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = _run("world", "grid", str(world_file), "--resolution", "0.1", "--inflate", "0.15",
               "--out", str(tmp_path / "g.npy"), "--ros-map", str(tmp_path / "map"))
    assert res.returncode == 0, res.stderr
    grid = np.load(tmp_path / "g.npy")
    assert grid.shape == (140, 120) and grid.dtype == bool and 0 < grid.mean() < 0.5
    assert (tmp_path / "map.yaml").exists() and (tmp_path / "map.pgm").exists()


def test_scan_prints_the_pybullet_lidar(world_file):
    res = _run("world", "scan", str(world_file), "--pose", "6", "7", "90", "--beams", "180")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    angles, ranges = np.array(out["angles_deg"]), np.array(out["ranges"])
    assert angles.shape == ranges.shape == (180,) and angles[90] == 0.0
    live = np.abs(angles) <= 180 - 7.5  # beams strictly inside the 15 deg blind sector read 0
    assert np.all(ranges[~live] == 0) and np.all(ranges[live] > 0)
    expected = assert_ranges_match_analytic(load_world(world_file), [[6.0, 7.0]],
                                            [math.pi / 2 + np.radians(angles[live])],
                                            ranges[None, live])
    assert (expected < 3.0).sum() > 10  # the comparison saw returns


def test_difficulty_prints_one_json_line_per_robot(world_file, tmp_path):
    # A 6 m x 2 m corridor, walls y <= 0.5 and y >= 1.5, one robot along y = 1.06 (row 21 of
    # 0.05 m cells). Inflated by r0 = 0.15 m (the config's default) the free rows are 13..26:
    # the nearest occupied row is 27, 6 cells up, and the vertical chord 5 + 8 cells; with
    # r0 = 0.2 m they are 14..25: 5 cells up, chord 4 + 7 cells.
    corridor = World("corridor", 0, (6.0, 2.0), (rectangle(0.0, 0.0, 6.0, 0.5, 1.0),
                                                 rectangle(0.0, 1.5, 6.0, 2.0, 1.0)),
                     np.array([[0.56, 1.06, 0.0]]), np.array([[5.46, 1.06]]))
    save_world(corridor, tmp_path / "c.json")
    for extra, distance, chord in (([], 0.30, 0.65), (["--set", "robot.r0_m=0.2"], 0.25, 0.55)):
        res = _run("world", "difficulty", str(tmp_path / "c.json"), *extra)
        assert res.returncode == 0, res.stderr
        (line,) = res.stdout.splitlines()
        out = json.loads(line)
        assert list(out) == ["robot", *MEASURES] and out["robot"] == 0
        assert out["distance_to_closest_obstacle_m"] == pytest.approx(distance, abs=1e-6)
        assert out["characteristic_dimension_m"] == pytest.approx(chord, abs=1e-6)
        assert out["tortuosity"] == pytest.approx(1.0, abs=1e-6)
    res = _run("world", "difficulty", str(world_file))
    assert res.returncode == 0, res.stderr
    rows = [json.loads(line) for line in res.stdout.splitlines()]
    expected = map_difficulty(load_world(world_file), r0_m=0.15)
    assert [r["robot"] for r in rows] == list(range(6))
    for name in MEASURES:
        np.testing.assert_allclose([r[name] for r in rows], expected[name], atol=1e-6)


@pytest.mark.parametrize(("args", "message"), [
    (["world", "difficulty", "{w}", "--set", "robot.r0_m=-1"], "robot.r0_m must be"),
    (["world", "difficulty", "{w}", "--set", "r0"], "--set expects KEY=VALUE"),
    (["world", "difficulty", "{d}/missing.json"], "No such file"),
    (["world", "difficulty", "{w}", "--set", "robot.r0_m=2", "--set", "robot.r_m=3"],
     "lies in an occupied cell"),
    (["world", "scan", "{w}", "--pose", "60", "7", "0"], "pose must lie in the world"),
    (["world", "scan", "{w}", "--pose", "6", "7", "0", "--beams", "1"], "beams must be an integer"),
    (["world", "grid", "{w}", "--resolution", "0", "--out", "{d}/g.npy"], "resolution_m must be"),
    (["world", "render", "{d}/missing.json", "--out", "{d}/x.png"], "No such file"),
    (["world", "render", "{d}/bad.json", "--out", "{d}/x.png"], "polygon is not convex"),
    (["world", "generate", "--env", "rocky", "--seed", "-2", "--out", "{d}/x.json"],
     "seed must be an integer >= 0"),
    (["world", "generate", "--env", "lava", "--seed", "1", "--out", "{d}/x.json"],
     "invalid choice"),
])
def test_bad_input_exits_2_with_one_stderr_line(world_file, tmp_path, args, message):
    bad = json.loads(world_file.read_text())
    bad["obstacles"].append({"shape": "polygon", "vertices": [[1, 1], [3, 1], [2, 1.5], [2, 3]],
                             "height": 1.0})
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    res = _run(*[a.format(w=world_file, d=tmp_path) for a in args])
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in res.stderr

