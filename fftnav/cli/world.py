"""``fftnav world {generate,render,grid,import,scan,difficulty}``: world files, pictures, grids,
ROS maps, lidar scans and how hard each robot's way is."""

from __future__ import annotations

import argparse
import io
import json
import math

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import check_distinct, check_target
from fftnav.world.kinds import world_kinds
from fftnav.world.model import BOUNDARIES


def cmd_generate(args: argparse.Namespace) -> int:
    """Generate a seeded world and write its JSON file."""
    from fftnav.world import generate_world, load_preset, save_world

    check_target(args.out, flag="--out")
    overrides = {}
    if args.size is not None:  # goals stay as far from the top edge as starts from the bottom
        overrides["size_m"] = list(args.size)
        overrides["goal_y_m"] = args.size[1] - load_preset(args.env)["start_y_m"]
    if args.density is not None:
        overrides["density_per_m2"] = args.density
    if args.robots is not None:
        overrides["robots"] = args.robots
    if args.boundary is not None:
        overrides["boundary"] = args.boundary
    world = generate_world(args.env, args.seed, **overrides)
    save_world(world, args.out)
    print(f"{args.out}: {args.env} seed {args.seed}, {len(world.obstacles)} obstacles, "
          f"{len(world.starts)} robots")
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    """Draw a world file top-down into an image."""
    from fftnav.report.world_plot import render_world
    from fftnav.world import load_world

    check_distinct({"--out": args.out}, inputs={"WORLD": args.world})
    check_target(args.out, flag="--out", image=True)
    world = load_world(args.world)
    render_world(world, args.out)  # written atomically
    print(args.out)
    return 0


def cmd_grid(args: argparse.Namespace) -> int:
    """Rasterise a world file into an occupancy grid (.npy, optionally a ROS map pair)."""
    from fftnav.files import write_atomic
    from fftnav.world import load_world
    from fftnav.world.grid import occupancy_grid, write_ros_map

    ros = {f"--ros-map ({suffix})": args.ros_map + suffix
           for suffix in (".pgm", ".yaml")} if args.ros_map else {}
    check_distinct({"--out": args.out, **ros}, inputs={"WORLD": args.world})
    out = check_target(args.out, flag="--out")
    for path in ros.values():
        check_target(path, flag="--ros-map")
    og = occupancy_grid(load_world(args.world), resolution_m=args.resolution,
                        inflate_m=args.inflate)
    buffer = io.BytesIO()
    np.save(buffer, og.grid)  # into memory: np.save(path) would append .npy to another name
    write_atomic(out, buffer.getvalue())
    print(f"{args.out}: {og.grid.shape[0]} rows (y) x {og.grid.shape[1]} cols (x), "
          f"{og.grid.mean():.1%} occupied")
    if args.ros_map:
        for path in write_ros_map(og, args.ros_map):
            print(path)
    return 0


def cmd_import(args: argparse.Namespace) -> int:
    """A world file from a ROS map_server map and starts/goals (options or a TOML file)."""
    from fftnav.cli import CliError
    from fftnav.world import save_world
    from fftnav.world.rosmap import import_ros_map, map_extent_text, read_robots_toml

    check_distinct({"--out": args.out}, inputs={"MAP.yaml": args.map, "--robots": args.robots})
    check_target(args.out, flag="--out")
    starts, goals = list(args.start or []), list(args.goal or [])
    if args.robots:
        s, g = read_robots_toml(args.robots)
        starts += s.tolist()
        goals += g.tolist()
    if not starts or len(starts) != len(goals):
        raise CliError(f"give as many --start X Y YAW_DEG as --goal X Y (or --robots R.toml), "
                       f"got {len(starts)} starts and {len(goals)} goals")
    world = import_ros_map(args.map, starts, goals, unknown=args.unknown)
    save_world(world, args.out)
    print(f"{args.out}: {map_extent_text(world)}")
    return 0


def cmd_scan(args: argparse.Namespace) -> int:
    """Print the PyBullet lidar scan of a robot at a pose as JSON."""
    from fftnav.config import SensorConfig
    from fftnav.sim.swarm import SimConfig, SwarmSim
    from fftnav.world import load_world

    world = load_world(args.world)
    x, y, yaw_deg = args.pose
    w, h = world.size_m
    if not (0 <= x <= w and 0 <= y <= h and math.isfinite(yaw_deg)):
        raise FftnavError(f"pose must lie in the world [0, {w:g}] x [0, {h:g}] with a finite yaw, "
                          f"got pose={args.pose}")
    probe = world.with_robots([[x, y, math.radians(yaw_deg)]], [[x, y]])
    config = SimConfig(sensor=SensorConfig(beams=args.beams, range_m=args.range,
                                           blind_deg=args.blind))
    with SwarmSim(probe, config=config) as sim:
        obs = sim.reset(seed=0)
        print(json.dumps({"angles_deg": np.degrees(sim.lidar.angles_rad).round(6).tolist(),
                          "ranges": obs.scans[0].round(6).tolist()}))
    return 0


def cmd_difficulty(args: argparse.Namespace) -> int:
    """Print BARN's difficulty measures along each robot's reference path, one JSON line per
    robot (:func:`fftnav.optimal.difficulty.map_difficulty`); r0 from the config."""
    from fftnav.cli.episode import _overrides
    from fftnav.config import SwarmConfig
    from fftnav.optimal.difficulty import MEASURES, map_difficulty
    from fftnav.world import load_world

    config = SwarmConfig().replace(_overrides(args.set or []))
    measures = map_difficulty(load_world(args.world), r0_m=config.robot.r0_m)
    for i in range(len(measures[MEASURES[0]])):
        values = (float(measures[name][i]) for name in MEASURES)
        print(json.dumps({"robot": i} | {name: round(v, 6) if math.isfinite(v) else None
                                         for name, v in zip(MEASURES, values, strict=True)}))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("world", help="generate, render, rasterise and scan worlds")
    cmds = p.add_subparsers(dest="world", metavar="ACTION", parser_class=type(p))
    cmds.required = True

    g = cmds.add_parser("generate", help="write a seeded forest or rocky world file")
    g.add_argument("--env", choices=world_kinds(), required=True)
    g.add_argument("--seed", type=int, required=True)
    g.add_argument("--size", type=float, nargs=2, metavar=("W", "H"),
                   help="metres; goals then lie on y = H - start_y_m")
    g.add_argument("--density", type=float, help="obstacles per m^2 of the whole world")
    g.add_argument("--robots", type=int, help="number of robots (starts and goals)")
    g.add_argument("--boundary", choices=BOUNDARIES,
                   help="map edge: open, or walls that stop robots and lidar (default: preset)")
    g.add_argument("--out", required=True, help="world JSON file to write")
    g.set_defaults(func=cmd_generate)

    r = cmds.add_parser("render", help="draw a world top-down (PNG, SVG, PDF)")
    r.add_argument("world", help="world JSON file")
    r.add_argument("--out", required=True, help="image file")
    r.set_defaults(func=cmd_render)

    q = cmds.add_parser("grid", help="occupancy grid (.npy, True = occupied, row = y from bottom)")
    q.add_argument("world", help="world JSON file")
    q.add_argument("--resolution", type=float, default=0.05, help="cell size, m (default 0.05)")
    q.add_argument("--inflate", type=float, default=0.0, help="inflate obstacles by M metres")
    q.add_argument("--out", required=True, help=".npy file to write")
    q.add_argument("--ros-map", metavar="PREFIX", help="also write PREFIX.yaml + PREFIX.pgm")
    q.set_defaults(func=cmd_grid)

    m = cmds.add_parser("import", help="a world file from a ROS map_server map (YAML + image)")
    m.add_argument("map", metavar="MAP.yaml", help="map_server YAML (image, resolution, origin, "
                   "negate, occupied_thresh, free_thresh, mode)")
    m.add_argument("--out", required=True, metavar="W.json", help="world JSON file to write")
    m.add_argument("--start", type=float, nargs=3, action="append", metavar=("X", "Y", "YAW"),
                   help="a robot's start in the map frame: metres, metres, degrees (repeatable)")
    m.add_argument("--goal", type=float, nargs=2, action="append", metavar=("X", "Y"),
                   help="its goal in the map frame, metres (repeatable, in --start order)")
    m.add_argument("--robots", metavar="R.toml",
                   help="starts and goals from [[robot]] tables: start = [x, y, yaw_deg], "
                   "goal = [x, y]")
    m.add_argument("--unknown", choices=("occupied", "free"), default="occupied",
                   help="what unknown cells become (default: occupied)")
    m.set_defaults(func=cmd_import)

    s = cmds.add_parser("scan", help="print the PyBullet lidar scan at a pose as JSON")
    s.add_argument("world", help="world JSON file")
    s.add_argument("--pose", type=float, nargs=3, metavar=("X", "Y", "YAW"), required=True,
                   help="metres, metres, degrees")
    s.add_argument("--beams", type=int, default=360)
    s.add_argument("--range", type=float, default=3.0, help="maximum range R, m")
    s.add_argument("--blind", type=float, default=15.0, help="blind sector at the back, degrees")
    s.set_defaults(func=cmd_scan)

    d = cmds.add_parser("difficulty", help="BARN's difficulty measures along each robot's "
                        "reference path, one JSON line per robot (docs/analysis.md)")
    d.add_argument("world", metavar="W.json", help="world JSON file")
    d.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a config parameter, e.g. --set robot.r0_m=0.2 (the robot's "
                   "radius inflates the map; repeatable; keys of docs/experiments.md)")
    d.set_defaults(func=cmd_difficulty)
