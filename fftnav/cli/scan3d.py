"""``fftnav scan3d FILE.npy``: safe-direction domain of one spherical depth image, as JSON."""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from fftnav.errors import FftnavError


def cmd_scan3d(args: argparse.Namespace) -> int:
    """Load a (rows, cols) depth image in metres and print its safe mask and summary. An image
    with fewer rows or columns than the disc filter gets an all-unsafe mask, no band and a
    ``reason`` (:func:`fftnav.observe.spherical.narrow_reason`), like a 2D scan narrower than
    the safety window."""
    from fftnav.files import load_npy
    from fftnav.limits import MAX_DEPTH_PIXELS, check_limit
    from fftnav.observe.geometry import RobotGeometry
    from fftnav.observe.spherical import DiscFilterBank, SphericalGrid, narrow_reason

    for flag, value, top in (("--fov-el", args.fov_el, 180.0), ("--fov-az", args.fov_az, 360.0)):
        if not 0 < value <= top:
            raise FftnavError(f"{flag} must be in (0, {top:g}] degrees, got {flag}={value:g}")
    depth = load_npy(args.file)
    if depth.ndim != 2:
        raise FftnavError(f"FILE must hold a 2D (rows, cols) depth image, got shape={depth.shape}")
    if not np.issubdtype(depth.dtype, np.number) or np.issubdtype(depth.dtype, np.complexfloating):
        raise FftnavError(f"FILE must hold real numbers, got dtype={depth.dtype}")
    check_limit(f"{args.file}: pixels", depth.size, MAX_DEPTH_PIXELS)
    grid = SphericalGrid(depth.shape[0], depth.shape[1], math.radians(args.fov_el),
                         math.radians(args.fov_az))
    geometry = RobotGeometry(r0_m=args.r0, r_m=args.r)
    reason = narrow_reason(grid, geometry=geometry, range_m=args.range)
    bands: list[dict[str, object]] = []
    if reason is None:
        bank = DiscFilterBank(grid, geometry=geometry, range_m=args.range)
        mask = bank.safe_mask(depth)
        bands = [{"rows": band.rows.size, "footprint": list(band.footprint.shape)}
                 for band in bank.bands]
    else:
        mask = np.zeros(depth.shape, dtype=bool)
    row = {
        "rows": grid.rows,
        "cols": grid.cols,
        "l_th_m": geometry.l_th_m,
        "alpha_deg": geometry.alpha_deg,
        "bands": bands,
        "safe_fraction": float(mask.mean()),
        "safe_mask": mask.astype(int).tolist(),
    }
    if reason is not None:
        row["reason"] = reason
    print(json.dumps(row))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "scan3d", help="safe directions of a spherical depth image (.npy, metres)",
        description="Row 0 is the top elevation (+fov_el/2), column 0 the azimuth -fov_az/2 "
                    "(-180 deg for a full circle). Prints one JSON object; an image with fewer "
                    "rows or columns than the disc filter has no safe direction, and a "
                    "'reason' says so.")
    p.add_argument("file", metavar="FILE.npy", help="2D depth image in metres (rows x cols)")
    p.add_argument("--fov-az", type=float, default=360.0, metavar="DEG",
                   help="azimuth field of view in degrees (default 360)")
    p.add_argument("--fov-el", type=float, default=90.0, metavar="DEG",
                   help="elevation field of view in degrees (default 90)")
    p.add_argument("--r0", type=float, default=0.15, metavar="M",
                   help="lateral collision radius r0 in metres (default 0.15, the paper's drone)")
    p.add_argument("--r", type=float, default=0.65, metavar="M",
                   help="protective radius r in metres (default 0.65, the paper's drone)")
    p.add_argument("--range", type=float, default=10.0, metavar="M",
                   help="maximum range R in metres (default 10)")
    p.set_defaults(func=cmd_scan3d)
