"""Worlds from ROS map_server maps: map_server's pixel semantics, exact rectangles, the round trip
through ``fftnav world grid --ros-map``, and an episode on an imported map."""

from __future__ import annotations

import csv
import re
import subprocess
import sys

import numpy as np
import pytest

from fftnav.world import generate_world, load_world, occupancy_grid, save_world
from fftnav.world.rosmap import grid_rectangles, import_ros_map, read_pgm, read_ros_map


def _yaml(path, image, *, resolution=0.1, origin=(0.0, 0.0, 0.0), **extra):
    lines = [f"image: {image}", f"resolution: {resolution}", f"origin: {list(origin)}"]
    lines += [f"{k}: {v}" for k, v in extra.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def _pgm(path, pixels, *, ascii_=False):
    rows, cols = pixels.shape
    if ascii_:
        body = "\n".join(" ".join(str(int(v)) for v in row) for row in pixels)
        path.write_text(f"P2\n# a comment\n{cols} {rows}\n255\n{body}\n")
    else:
        path.write_bytes(f"P5\n# made by hand\n{cols} {rows}\n255\n".encode()
                         + pixels.astype(np.uint8).tobytes())
    return path


# top image row first: 0 black (occupied), 254 free, 205 = ROS "unknown" grey, 100 (p = 0.61)
PIXELS = np.array([[0, 254, 205],
                   [100, 254, 0]])


@pytest.mark.parametrize("ascii_", [False, True])
def test_map_server_trinary_semantics(tmp_path, ascii_):
    _pgm(tmp_path / "m.pgm", PIXELS, ascii_=ascii_)
    assert np.array_equal(read_pgm(tmp_path / "m.pgm"), PIXELS)
    ros = read_ros_map(_yaml(tmp_path / "m.yaml", "m.pgm"))
    p = (255 - PIXELS) / 255  # map_server: occupied p > 0.65, free p < 0.196, else unknown
    expect = np.where(p > 0.65, 1, np.where(p < 0.196, 0, -1))
    assert np.array_equal(ros.occupancy, np.flipud(expect))  # row 0 = bottom of the map
    ros = read_ros_map(_yaml(tmp_path / "n.yaml", "m.pgm", negate=1, occupied_thresh=0.5,
                             free_thresh=0.1))
    p = PIXELS / 255
    assert np.array_equal(ros.occupancy, np.flipud(np.where(p > 0.5, 1, np.where(p < 0.1, 0, -1))))


def test_png_colour_channels_are_averaged(tmp_path):
    from PIL import Image

    rgb = np.zeros((2, 2, 3), dtype=np.uint8)
    rgb[0, 0] = (255, 255, 255)  # white: free
    rgb[0, 1] = (255, 0, 0)  # mean 85: p = 0.67 > 0.65, occupied
    rgb[1, 0] = (255, 255, 0)  # mean 170: p = 0.33, unknown
    Image.fromarray(rgb).save(tmp_path / "m.png")
    ros = read_ros_map(_yaml(tmp_path / "m.yaml", "m.png"))
    assert ros.occupancy.tolist() == [[-1, 1], [0, 1]]


def test_rectangles_cover_exactly_the_occupied_cells():
    rng = np.random.default_rng(5)
    grid = rng.random((40, 30)) < 0.3
    rects = grid_rectangles(grid)
    painted = np.zeros(grid.shape, dtype=int)
    for r0, r1, c0, c1 in rects:
        painted[r0:r1, c0:c1] += 1
    assert np.array_equal(painted, grid.astype(int))  # exact and disjoint
    runs = sum(np.count_nonzero(np.diff(np.r_[0, row.astype(int), 0]) == 1) for row in grid)
    assert len(rects) < runs
    block = np.zeros((20, 20), dtype=bool)
    block[5:15, 3:18] = True  # a wall block is one obstacle, an L two
    assert grid_rectangles(block) == [(5, 15, 3, 18)]
    block[15:18, 3:6] = True
    assert grid_rectangles(block) == [(5, 15, 3, 18), (15, 18, 3, 6)]


@pytest.mark.parametrize("resolution", [0.05, 0.1])
def test_round_trip_through_a_ros_map_gives_the_same_grid(tmp_path, resolution):
    world = generate_world("forest", 4, robots=3, size_m=[8.0, 8.0], goal_y_m=7.0)
    save_world(world, tmp_path / "w.json")
    subprocess.run([sys.executable, "-m", "fftnav", "world", "grid", str(tmp_path / "w.json"),
                    "--resolution", str(resolution), "--out", str(tmp_path / "g.npy"),
                    "--ros-map", str(tmp_path / "map")], check=True, capture_output=True)
    starts = np.c_[world.starts[:, :2], np.degrees(world.starts[:, 2])]
    back = import_ros_map(tmp_path / "map.yaml", starts, world.goals)
    original = occupancy_grid(world, resolution_m=resolution).grid
    assert np.array_equal(original, np.load(tmp_path / "g.npy"))
    assert np.array_equal(occupancy_grid(back, resolution_m=resolution).grid, original)
    assert np.allclose(back.starts, world.starts) and np.allclose(back.goals, world.goals)


def test_origin_shifts_the_map_into_the_world_frame(tmp_path):
    pixels = np.full((20, 30), 254)
    pixels[0:5, 10:12] = 0  # a wall at the top of the image
    _pgm(tmp_path / "m.pgm", pixels)
    yaml = _yaml(tmp_path / "m.yaml", "m.pgm", resolution=0.2, origin=(-3.0, 1.0, 0.0))
    world = import_ros_map(yaml, [[-2.0, 2.0, 90.0]], [[2.0, 4.0]])
    assert world.size_m == pytest.approx((6.0, 4.0))
    assert world.starts[0] == pytest.approx([1.0, 1.0, np.pi / 2])
    assert world.goals[0] == pytest.approx([5.0, 3.0])
    assert len(world.obstacles) == 1
    lo, hi = world.obstacles[0].bounds()
    assert lo == pytest.approx([2.0, 3.0]) and hi == pytest.approx([2.4, 4.0])


@pytest.mark.parametrize(("kwargs", "starts", "match"), [
    ({"origin": (0.0, 0.0, 0.5)}, [[1, 1, 0]], r"origin yaw must be 0"),
    ({"negate": 2}, [[1, 1, 0]], r"negate must be one of \[0, 1\], got negate=2"),
    ({"resolution": -1}, [[1, 1, 0]], r"resolution must be a finite number in \[0.0001, 1000\]"),
    ({"resolution": "1e-300"}, [[1, 1, 0]],
     r"resolution must be a finite number in \[0.0001, 1000\], got resolution=1e-300$"),
    ({"resolution": "5e1"}, [[1, 1, 0]], r"m\.pgm: map side \(30 pixels x resolution 50 m\): "
     r"1,500 estimated, above the limit of 1,000"),
    ({}, [[2.1, 1.8, 0]], r"starts\[0\] lies inside obstacles\[0\]"),
])
def test_bad_maps_and_robots_are_refused(tmp_path, kwargs, starts, match):
    pixels = np.full((20, 30), 254)
    pixels[0:5, 20:22] = 0
    _pgm(tmp_path / "m.pgm", pixels)
    yaml = _yaml(tmp_path / "m.yaml", "m.pgm", **{"resolution": 0.1, **kwargs})
    with pytest.raises(ValueError, match=match):
        import_ros_map(yaml, starts, [[0.5, 0.5]])


@pytest.mark.slow
def test_an_imported_map_runs_an_episode_from_the_command_line(tmp_path):
    pixels = np.full((60, 40), 254)  # 4 m x 6 m room at 0.1 m, a wall across the middle
    pixels[:, 0] = pixels[:, -1] = pixels[0, :] = pixels[-1, :] = 0
    pixels[29:31, 0:26] = 0
    _pgm(tmp_path / "room.pgm", pixels)
    _yaml(tmp_path / "room.yaml", "room.pgm", origin=(-2.0, -3.0, 0.0))
    (tmp_path / "robots.toml").write_text(
        "[[robot]]\nstart = [-1.0, -2.0, 90.0]\ngoal = [-1.0, 2.0]\n")

    def fftnav(*args):
        return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True,
                              text=True, cwd=tmp_path, timeout=300)

    proc = fftnav("world", "import", "room.yaml", "--robots", "robots.toml", "--out", "w.json")
    assert proc.returncode == 0, proc.stderr
    world = load_world(tmp_path / "w.json")
    assert world.size_m == pytest.approx((4.0, 6.0)) and len(world.obstacles) <= 6
    proc = fftnav("episode", "--world", "w.json", "--policy", "bug-right", "--out", "e.csv",
                  "--set", "time_limit_s=60")
    assert proc.returncode == 0, proc.stderr
    row = (tmp_path / "e.csv").read_text().splitlines()[1].split(",")
    assert row[2] == "true" and row[3] == "false"  # arrived, no collision
    assert float(row[5]) > 4.0  # the optimal path goes around the wall (A* on the import)
    bad = fftnav("world", "import", "room.yaml", "--start", "0", "0", "0", "--out", "x.json")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
    assert "as many --start X Y YAW_DEG as --goal X Y" in bad.stderr


@pytest.mark.slow
def test_an_imported_map_runs_as_an_experiment_env(tmp_path):
    """``[world_files]`` names an imported world as an env of ``fftnav run``: its rows carry the
    env's name, the world file's hash guards a resume, bad entries are refused in one line."""
    pixels = np.full((50, 30), 254)  # 3 m x 5 m room at 0.1 m, a wall from the left
    pixels[:, 0] = pixels[:, -1] = pixels[0, :] = pixels[-1, :] = 0
    pixels[24:26, 0:18] = 0
    _pgm(tmp_path / "room.pgm", pixels)
    _yaml(tmp_path / "room.yaml", "room.pgm")
    (tmp_path / "robots.toml").write_text(
        "[[robot]]\nstart = [0.6, 0.6, 90.0]\ngoal = [0.6, 4.4]\n"
        "[[robot]]\nstart = [2.4, 0.6, 90.0]\ngoal = [2.4, 4.4]\n")
    maps = tmp_path / "maps"
    maps.mkdir()

    def fftnav(*args):
        return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True,
                              text=True, cwd=tmp_path, timeout=600)

    proc = fftnav("world", "import", "room.yaml", "--robots", "robots.toml",
                  "--out", "maps/room.json")
    assert proc.returncode == 0, proc.stderr
    config = ('[experiment]\nname = "room"\nenvs = ["room"]\nmaps = 2\nmap_seed = 0\n'
              'robots = {robots}\npolicies = ["bug-right"]\n'
              '[world_files]\nroom = "{path}"\n[episode]\ntime_limit_s = 40.0\n')
    (maps / "room.toml").write_text(config.format(robots=2, path="room.json"))  # relative
    proc = fftnav("run", "maps/room.toml", "--out", "out", "--workers", "1", "--quiet")
    assert proc.returncode == 0, proc.stderr
    episodes = (tmp_path / "out" / "episodes.csv").read_text().splitlines()
    assert len(episodes) == 1 + 2 * 2  # maps x robots
    summary = (tmp_path / "out" / "summary.csv").read_text().splitlines()
    assert [line.split(",")[:2] for line in summary[1:]] == [["room", "bug-right"]]
    assert "world_sha256" in (tmp_path / "out" / "config.json").read_text()
    # every map is the imported world: each robot's optimal length is the same on both maps,
    # and the robot behind the wall (robot 0) has to go round it
    rows = list(csv.DictReader(episodes))
    optimal = {(r["robot"], r["map_seed"]): float(r["optimal_length_m"]) for r in rows}
    for robot in ("0", "1"):
        assert optimal[robot, "0"] == optimal[robot, "1"]
    assert optimal["0", "0"] > optimal["1", "0"] + 0.5
    # a changed world file is refused when resuming, in one line
    world = load_world(maps / "room.json")
    save_world(world.with_robots(world.starts[::-1], world.goals[::-1]), maps / "room.json")
    again = fftnav("run", "maps/room.toml", "--out", "out", "--workers", "1", "--quiet")
    assert again.returncode == 2 and again.stderr.count("\n") == 1, again.stderr
    for text, match in [(config.format(robots=3, path="room.json"),
                         "world_files.room: .* has 2 robots"),
                        (config.format(robots=2, path="nothere.json"), "world_files.room: "),
                        (config.replace("room = ", "forest = ").format(robots=2, path="room.json"),
                         "world_files.forest: 'forest' is a registered world kind")]:
        (maps / "bad.toml").write_text(text)
        bad = fftnav("run", "maps/bad.toml", "--out", "bad", "--quiet")
        assert bad.returncode == 2 and bad.stderr.count("\n") == 1, bad.stderr
        assert re.search(match, bad.stderr), bad.stderr
        assert not (tmp_path / "bad").exists()


def test_yaml_numbers_are_read_as_map_server_reads_them(tmp_path):
    """PyYAML reads ``5e-2`` (YAML 1.1) as a string; map_server's yaml-cpp as a number."""
    _pgm(tmp_path / "m.pgm", np.full((20, 30), 254))
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 5e-2\norigin: [-1e0, .5, 0]\n"
                                     "occupied_thresh: 6.5e-1\n")
    ros = read_ros_map(tmp_path / "m.yaml")
    assert ros.resolution_m == 0.05 and ros.origin_m == (-1.0, 0.5)
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 5e-2x\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match=r"resolution must be a finite number in \[0\.0001, "
                                         r"1000\], got resolution='5e-2x'"):
        read_ros_map(tmp_path / "m.yaml")


def _pgm_header_only(path, cols, rows):
    """A P5 header claiming cols x rows pixels, its pixels a sparse hole (no disk used)."""
    header = f"P5\n{cols} {rows}\n255\n".encode()
    with open(path, "wb") as fh:
        fh.write(header)
        fh.truncate(len(header) + cols * rows)
    return path


@pytest.mark.parametrize(("cols", "rows"), [(100_000, 100_000), (20_000, 20_000)])
def test_huge_pgm_maps_are_refused_from_the_header(tmp_path, cols, rows):
    """A 100000 x 100000 header and a 20000 x 20000 map (above the 100M-cell grid limit), both
    sparse files as large as they claim: refused before any pixel is read."""
    _pgm_header_only(tmp_path / "m.pgm", cols, rows)
    _yaml(tmp_path / "m.yaml", "m.pgm", resolution=0.01)
    with pytest.raises(ValueError, match=rf"m\.pgm: map cells \({cols} x {rows} pixels\): "
                                         rf"{cols * rows:,} estimated, above the limit of "
                                         r"100,000,000"):
        read_ros_map(tmp_path / "m.yaml")


def _png_header_only(path, cols, rows):
    """An 8-bit grey PNG claiming cols x rows pixels, with a few bytes of pixel data."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", cols, rows, 8, 0, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(bytes(64))) + chunk(b"IEND", b""))


def test_a_png_bomb_is_refused_by_the_grid_limit(tmp_path):
    """A 40000 x 40000 PNG header (1.6 billion pixels): Pillow's DecompressionBombError becomes
    the grid limit's one line; 12000 x 12000 (under Pillow's own limit) is refused too."""
    for name, side in (("bomb", 40_000), ("big", 12_000)):
        _png_header_only(tmp_path / f"{name}.png", side, side)
        _yaml(tmp_path / f"{name}.yaml", f"{name}.png", resolution=0.01)
        with pytest.raises(ValueError, match=rf"{name}\.png: map cells .*: {side * side:,} "
                                             r"estimated, above the limit of 100,000,000"):
            read_ros_map(tmp_path / f"{name}.yaml")


@pytest.mark.parametrize(("content", "match"), [
    (b"", r"g\.pgm: not a PGM file \(truncated header\)"),
    (b"P5\n30", r"g\.pgm: not a PGM file \(truncated header\)"),
    (b"GIF89a garbage garbage garbage", r"g\.pgm: not a grey PGM \(P2/P5 magic"),
    (b"P5\n30 x20\n255\n", r"g\.pgm: not a grey PGM \(P2/P5 magic, then width, height"),
    (b"P5\n30 20\n255\n" + bytes(100), r"g\.pgm: PGM holds 100 pixels, expected 20 x 30 "
     r"\(truncated\)"),
    (b"P2\n3 2\n255\n1 2 3 4", r"g\.pgm: PGM holds 4 pixels, expected 2 x 3"),
    (b"P5\n30 20\n0\n", r"g\.pgm: not a grey PGM, got 30 x 20 pixels, maxval 0"),
])
def test_garbage_or_truncated_pgm_is_refused_naming_the_file(tmp_path, content, match):
    (tmp_path / "g.pgm").write_bytes(content)
    with pytest.raises(ValueError, match=match):
        read_ros_map(_yaml(tmp_path / "m.yaml", "g.pgm"))


def test_blocks_of_rows_give_the_whole_image_map(tmp_path, monkeypatch):
    """Classified 7 rows at a time, a 50-row map (PGM and PNG) is the same as in one block."""
    from PIL import Image

    pixels = np.random.default_rng(1).integers(0, 256, (50, 40))
    _pgm(tmp_path / "m.pgm", pixels)
    Image.fromarray(pixels.astype(np.uint8)).save(tmp_path / "m.png")
    for image in ("m.pgm", "m.png"):
        yaml = _yaml(tmp_path / f"{image}.yaml", image)
        whole = read_ros_map(yaml).occupancy
        monkeypatch.setattr("fftnav.world.rosmap.BLOCK_ROWS", 7)
        assert np.array_equal(read_ros_map(yaml).occupancy, whole)
        monkeypatch.undo()
        p = (255 - pixels) / 255
        assert np.array_equal(whole, np.flipud(np.where(p > 0.65, 1, np.where(p < 0.196, 0, -1))))
