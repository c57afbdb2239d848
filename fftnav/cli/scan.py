"""``fftnav scan FILE``: run the observation pipeline on every scan of a file, JSON Lines out."""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from typing import Any

import numpy as np

from fftnav.errors import FftnavError

#: Model range R for CARMEN logs (real indoor 2D lidar; "no return" ~81 m reads as R).
CARMEN_RANGE_M = 10.0
#: Model range R of the paper's simulated lidar.
SIM_RANGE_M = 3.0


#: Scans per chunk streamed from the file (at most 4096 x 360 readings: wide scans come fewer).
CHUNK_SCANS = 4096


def cmd_scan(args: argparse.Namespace) -> int:
    """Process the scans of ``args.file`` a chunk at a time (:func:`fftnav.observe.scanio.
    iter_scans`: bounded memory at any file size) and print one JSON object per scan.

    The rows are laid out as :meth:`fftnav.ros.laserscan.Layout.of_fov` says (a full circle
    from -pi, filtered with wrap-around; a partial field of view centred on the heading); a
    field of view narrower than the safety window gives every scan a line with no safe beam
    and a ``reason`` (:class:`fftnav.ros.laserscan.LayoutPipelines`)."""
    from fftnav.limits import MAX_BEAMS, check_limit
    from fftnav.observe.geometry import REAL_ROBOT, SIM_ROBOT, RobotGeometry
    from fftnav.observe.scanio import iter_scans
    from fftnav.ros import is_bag
    from fftnav.ros.laserscan import Layout, LayoutPipelines

    if is_bag(args.file):
        return _scan_bag(args)
    if args.topic is not None or args.out_bag is not None:
        raise FftnavError(f"--topic and --out-bag need a bag (.bag, .db3, .mcap or a ROS 2 bag "
                          f"folder), got {args.file!r}")
    data = iter_scans(args.file, format=args.format, rows=CHUNK_SCANS)
    first = next(data.chunks)
    beams = first.shape[1]
    check_limit(f"{args.file}: beams per scan", beams, MAX_BEAMS)
    carmen = data.format == "carmen"
    default = REAL_ROBOT if carmen else SIM_ROBOT
    r0 = args.r0 if args.r0 is not None else default.r0_m
    r = args.r if args.r is not None else default.r_m
    range_m = args.range if args.range is not None else (CARMEN_RANGE_M if carmen else SIM_RANGE_M)
    if args.fov is not None:
        fov = math.radians(args.fov)
    else:
        fov = data.fov_rad if data.fov_rad is not None else 2.0 * math.pi
    layout = Layout.of_fov(beams, fov)
    pipe = LayoutPipelines(RobotGeometry(r0_m=r0, r_m=r)).get(layout, range_m)
    index = 0
    for chunk in itertools.chain([first], data.chunks):
        sys.stdout.write("".join(_json_lines(layout, pipe, chunk, index)))
        index += len(chunk)
    return 0


def _json_lines(layout: Any, pipe: Any, chunk: np.ndarray, start: int) -> list[str]:
    """One JSON line per scan of a chunk ``(k, M)`` through ``pipe`` (None: the layout is
    narrower than the safety window), numbered from ``start``."""
    from fftnav.ros.laserscan import LayoutPipelines

    if pipe is None:
        narrow = json.dumps(LayoutPipelines.narrow(layout).fields(), separators=(",", ":"))
        return [f'{{"index":{start + i},{narrow[1:]}\n' for i in range(len(chunk))]
    res = pipe.process(chunk)
    return [json.dumps({"index": start + i, **LayoutPipelines.result(layout, pipe, res, i)
                        .fields()}, separators=(",", ":")) + "\n" for i in range(len(chunk))]


def _scan_bag(args: argparse.Namespace) -> int:
    """``fftnav scan BAG``: the LaserScans of a topic (:func:`fftnav.ros.bags.scan_bag`); the
    real robot by default, as for CARMEN logs, and R from each message's ``range_max``."""
    from fftnav.observe.geometry import REAL_ROBOT, RobotGeometry
    from fftnav.ros.bags import scan_bag

    if args.fov is not None or args.format != "auto":
        raise FftnavError("--fov and --format do not apply to bags: each LaserScan gives its own "
                          "field of view")
    geometry = RobotGeometry(r0_m=REAL_ROBOT.r0_m if args.r0 is None else args.r0,
                             r_m=REAL_ROBOT.r_m if args.r is None else args.r)
    scan_bag(args.file, topic=args.topic, geometry=geometry, range_m=args.range,
             write=sys.stdout.write, out_bag=args.out_bag)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "scan",
        help="safe directions, extrema and messages of every scan in a file (JSON Lines)",
        description=(
            "Run the FFT observation pipeline on every scan of FILE and print one JSON object "
            "per scan. Defaults: the paper's simulation robot (r0=0.15, r=0.3), R=3 m, 360 deg; "
            "for CARMEN logs the real robot (r0=0.29, r=0.7), R=10 m, 180 deg; for ROS bags "
            "the real robot, with R and the field of view of each LaserScan."
        ),
    )
    p.add_argument(
        "file", metavar="FILE", help=".npy (M or K x M), .csv (one scan per row), .log[.gz], "
        "or a ROS bag: .bag, .db3, .mcap or a ROS 2 bag folder (extra fftnav[ros])"
    )
    p.add_argument("--format", choices=("auto", "npy", "csv", "carmen"), default="auto")
    p.add_argument("--r0", type=float, metavar="M", help="lateral collision radius r0 (m)")
    p.add_argument("--r", type=float, metavar="M", help="protective radius r (m)")
    p.add_argument("--range", type=float, metavar="M", help="maximum range R (m)")
    p.add_argument("--fov", type=float, metavar="DEG", help="field of view (degrees)")
    p.add_argument("--topic", metavar="T", help="bags: the LaserScan topic (default: the only one)")
    p.add_argument("--out-bag", metavar="OUT",
                   help="bags: write the bag again with /fftnav/safe_scan and "
                   "/fftnav/safe_directions (docs/pipeline.md, \"Your robot's data\")")
    p.set_defaults(func=cmd_scan)
