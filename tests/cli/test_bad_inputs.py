"""Every bad input of the corpus tests/data/bad/ is refused in one line by every reader and CLI
command that takes it: a ValueError naming the file from the library, exit status 2 and exactly
one ``fftnav CMD: error: ...`` line from the CLI, no traceback, no output file written.

The corpus (one file per kind of damage, see tests/data/bad/README.md) holds damaged arrays,
archives, gzip streams, CARMEN logs with impossible sensor parameters, undecodable text,
deeply nested JSON, world files with unknown keys or absurd sizes, and experiment configs
whose values would fail every episode, hang, or allocate without bound.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fftnav.cli import main
from fftnav.files import load_npz, read_json, read_toml
from fftnav.observe.scanio import read_scans
from fftnav.runner import load_config
from fftnav.world import load_world

BAD = Path(__file__).resolve().parents[1] / "data" / "bad"
SCANS = sorted(p.name for p in BAD.iterdir() if p.suffix in (".npy", ".csv", ".log", ".gz"))
WORLDS = sorted(p.name for p in BAD.glob("*.json"))
CONFIGS = sorted(p.name for p in BAD.glob("*.toml"))
MAPS = sorted(p.name for p in BAD.glob("map_*.yaml"))
GOOD_WORLD = Path(__file__).resolve().parents[2] / "worlds"  # presets (TOML), not world files


def _refused(capsys, argv: list[str], tmp_path: Path) -> str:
    """Run the CLI in-process (an uncaught exception fails the test with its traceback);
    return its one stderr line after checking the exit status and that nothing was written."""
    before = set(tmp_path.rglob("*"))
    status = main(argv)
    out, err = capsys.readouterr()
    assert status == 2, (argv, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert out == ""
    assert set(tmp_path.rglob("*")) == before, "a refused command wrote a file"
    return lines[0]


def test_the_corpus_is_there():
    assert len(SCANS) >= 15 and len(WORLDS) >= 6 and len(CONFIGS) >= 18 and len(MAPS) >= 6


@pytest.mark.parametrize("name", SCANS)
def test_scan_readers_refuse_naming_the_file(name):
    with pytest.raises(ValueError, match=name.replace(".", r"\.")):
        read_scans(BAD / name)


@pytest.mark.parametrize("name", SCANS)
def test_fftnav_scan_and_scan3d_refuse_in_one_line(name, capsys, tmp_path):
    line = _refused(capsys, ["scan", str(BAD / name)], tmp_path)
    assert line.startswith("fftnav scan: error: ") and name in line
    if name.endswith(".npy"):
        line = _refused(capsys, ["scan3d", str(BAD / name)], tmp_path)
        assert line.startswith("fftnav scan3d: error: ") and name in line


@pytest.mark.parametrize("name", WORLDS)
def test_world_readers_and_every_command_that_reads_worlds_refuse(name, capsys, tmp_path):
    with pytest.raises(ValueError, match=name.replace(".", r"\.")):
        load_world(BAD / name)
    world = str(BAD / name)
    for argv in (["world", "render", world, "--out", str(tmp_path / "w.png")],
                 ["world", "grid", world, "--out", str(tmp_path / "g.npy")],
                 ["world", "scan", world, "--pose", "1", "1", "0"],
                 ["episode", "--world", world, "--policy", "fusion",
                  "--out", str(tmp_path / "e.csv")]):
        line = _refused(capsys, argv, tmp_path)
        assert line.startswith(f"fftnav {argv[0]}: error: ") and name in line, line


@pytest.mark.parametrize("name", CONFIGS)
def test_configs_are_refused_at_load_before_any_folder_exists(name, capsys, tmp_path):
    with pytest.raises(ValueError, match=name.replace(".", r"\.")):
        load_config(BAD / name)
    out = tmp_path / "out"
    line = _refused(capsys, ["run", str(BAD / name), "--out", str(out), "--quiet"], tmp_path)
    assert line.startswith("fftnav run: error: ") and name in line
    assert not out.exists()


@pytest.mark.parametrize("name", MAPS)
def test_ros_maps_are_refused_naming_the_file_before_any_pixel_is_read(name, capsys, tmp_path):
    """Huge headers (100000 x 100000, 20000 x 20000 PGM; a 40000 x 40000 PNG bomb), garbage
    and truncated PGMs, a resolution of 1e-300: one line naming the map or its image."""
    from fftnav.world.rosmap import read_ros_map

    image = (BAD / name).read_text().split()[1]  # "image: NAME"
    named = rf"({name}|{image})".replace(".", r"\.")
    with pytest.raises(ValueError, match=named):
        read_ros_map(BAD / name)
    line = _refused(capsys, ["world", "import", str(BAD / name), "--start", "0.1", "0.1", "0",
                             "--goal", "0.2", "0.2", "--out", str(tmp_path / "w.json")],
                    tmp_path)
    assert line.startswith("fftnav world: error: ") and (name in line or image in line), line


@pytest.mark.parametrize(("argv", "match"), [
    (["scan3d", "{bad}/truncated.npy", "--fov-el", "1e-9"], "truncated.npy"),
    (["scan3d", "{depth}", "--fov-el", "1e-9"], r"disc footprint cells .* above the limit"),
    (["scan3d", "{depth}", "--r", "1e300"], r"r_m must keep l_th = r_m\^2 / r0_m finite"),
    (["scan", "{depth}", "--r", "1e300"], r"r_m must keep l_th = r_m\^2 / r0_m finite"),
    (["world", "generate", "--env", "forest", "--seed", "1", "--size", "1e300", "1e300",
      "--out", "{tmp}/w.json"], r"size_m\[0\] must be a finite number in \(0, 1000\]"),
    (["world", "generate", "--env", "forest", "--seed", "1", "--size", "2000", "2000",
      "--out", "{tmp}/w.json"], r"size_m\[0\] must be a finite number in \(0, 1000\]"),
    (["world", "generate", "--env", "forest", "--seed", "1", "--size", "1000", "1000",
      "--density", "0.01", "--out", "{tmp}/w.json"],
     r"reachability grid cells .*: 400,000,000 estimated, above the limit of 100,000,000"),
    (["world", "grid", "{world}", "--resolution", "1e300", "--out", "{tmp}/g.npy"],
     r"resolution_m must be a finite number in \(0, 8\], got resolution_m=1e\+300"),
    (["world", "grid", "{world}", "--resolution", "1e-6", "--out", "{tmp}/g.npy"],
     r"grid cells \(world size / resolution_m\): 64,000,000,000,000 estimated"),
    (["world", "grid", "{world}", "--out", "{tmp}"], r"--out must be a file path, not a folder"),
    (["world", "scan", "{world}", "--pose", "1", "1", "0", "--beams", "100000000"],
     r"beams must be an integer in \[2, 100000\]"),
    (["figure", "depth3d", "--seed", "-1", "--out", "{tmp}/f"],
     r"--seed must be an integer >= 0, got --seed=-1"),
])
def test_absurd_options_are_refused_in_one_line(argv, match, capsys, tmp_path):
    import numpy as np

    from fftnav.world import generate_world, save_world

    work = tmp_path / "in"
    work.mkdir()
    np.save(work / "depth.npy", np.full((30, 120), 5.0))
    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=3),
               work / "world.json")
    names = {"bad": str(BAD), "depth": str(work / "depth.npy"), "world": str(work / "world.json"),
             "tmp": str(tmp_path / "out")}
    (tmp_path / "out").mkdir()
    argv = [a.format(**names) for a in argv]
    line = _refused(capsys, argv, tmp_path / "out")
    import re
    assert re.search(match, line), line


def test_gui_without_a_display_is_refused_in_one_line(tmp_path):
    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=3),
               tmp_path / "w.json")
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    proc = subprocess.run([sys.executable, "-m", "fftnav", "episode", "--world",
                           str(tmp_path / "w.json"), "--policy", "fusion", "--gui"],
                          capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 2 and proc.stderr == (
        "fftnav episode: error: gui needs a display, got DISPLAY unset (run without --gui, or "
        "with a virtual display such as xvfb-run)\n")


def test_world_grid_writes_exactly_the_named_path(tmp_path, capsys):
    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=3),
               tmp_path / "w.json")
    assert main(["world", "grid", str(tmp_path / "w.json"), "--out", str(tmp_path / "g")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g", "w.json"]
    import numpy as np

    assert np.load(tmp_path / "g").shape == (160, 160)


def test_other_readers_name_the_file():
    with pytest.raises(ValueError, match=r"truncated\.npz: damaged \.npz archive"):
        load_npz(BAD / "truncated.npz")
    with pytest.raises(ValueError, match=r"deep\.json: JSON nested 100000 levels deep"):
        read_json(BAD / "deep.json")
    with pytest.raises(ValueError, match=r"deep\.toml: invalid TOML"):
        read_toml(BAD / "deep.toml")


def test_a_bad_file_is_one_line_and_exit_2_from_the_installed_command():
    """The same through a real process: exit status 2, one line, for a few kinds of damage."""
    for argv in (["scan", str(BAD / "archive_named.npy")], ["scan", str(BAD / "param_zero.log")],
                 ["world", "render", str(BAD / "deep.json"), "--out", "/nonexistent/x.png"],
                 ["run", str(BAD / "config_maps_billion.toml"), "--out", "/nonexistent/x"]):
        proc = subprocess.run([sys.executable, "-m", "fftnav", *argv], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 2 and proc.stdout == "", (argv, proc.stderr)
        assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_huge_ranges_give_the_right_answer_not_every_beam_safe(tmp_path, capsys):
    """The reported wrong answers: 0.2 m everywhere (l_th = 0.6 m) at R = 1e9 m, and a wall at
    1 m in every direction of a depth image at R = 1e300 m, are nowhere safe."""
    import json

    import numpy as np

    np.save(tmp_path / "near.npy", np.full((2, 360), 0.2))
    assert main(["scan", str(tmp_path / "near.npy"), "--range", "1e9"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(rows) == 2 and all(sum(r["safe_mask"]) == 0 for r in rows)
    assert main(["scan", str(tmp_path / "near.npy"), "--range", "1e300"]) == 0  # no overflow
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(rows) == 2 and all(sum(r["safe_mask"]) == 0 for r in rows)
    np.save(tmp_path / "wall.npy", np.full((30, 120), 1.0))
    assert main(["scan3d", str(tmp_path / "wall.npy"), "--range", "1e300"]) == 0
    assert json.loads(capsys.readouterr().out)["safe_fraction"] == 0.0


def test_a_60m_forest_generates_and_scans(tmp_path, capsys):
    """The 60 m x 60 m forest (720 trunks, two static meshes) that crashed the simulator."""
    import json

    world = str(tmp_path / "f60.json")
    assert main(["world", "generate", "--env", "forest", "--seed", "1", "--size", "60", "60",
                 "--out", world]) == 0
    assert "720 obstacles" in capsys.readouterr().out
    assert main(["world", "scan", world, "--pose", "30", "30", "90"]) == 0
    ranges = json.loads(capsys.readouterr().out)["ranges"]
    assert len(ranges) == 360 and max(ranges) <= 3.0


def test_a_failed_write_leaves_no_temporary_file(tmp_path):
    from fftnav.files import write_atomic

    class FullDisk(str):
        def encode(self, *args):
            raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        write_atomic(tmp_path / "x.csv", FullDisk("data"))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv, match", [
    (["episode", "--world", "w.json", "--policy", "fusion", "--out", "x.csv", "--record",
      "x.csv"], r"--out and --record name the same file, got --record='x.csv'"),
    (["episode", "--world", "w.json", "--policy", "fusion", "--trajectories", "t.npz", "--record",
      "./t.npz"], r"--record and --trajectories name the same file"),
    (["episode", "--world", "w.json", "--policy", "fusion", "--out", "w.json"],
     r"--world and --out name the same file, got --out='w.json'"),
    (["world", "render", "w.json", "--out", "w.json"], r"WORLD and --out name the same file"),
])
def test_one_file_named_by_two_options_is_refused_before_any_work(tmp_path, argv, match):
    import re

    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 1, robots=2), tmp_path / "w.json")
    before = sorted((p.name, p.stat().st_mtime_ns) for p in tmp_path.iterdir())
    res = subprocess.run([sys.executable, "-m", "fftnav", *argv], cwd=tmp_path,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and re.search(match, res.stderr), res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert sorted((p.name, p.stat().st_mtime_ns) for p in tmp_path.iterdir()) == before
