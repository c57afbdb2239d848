"""``fftnav fly3d``: quadrotor flights through seeded 3D forests, steered by the safe domain."""

from __future__ import annotations

import argparse
import csv
import io
import json

from fftnav.errors import FftnavError


def cmd_fly3d(args: argparse.Namespace) -> int:
    """Fly seeds ``first .. first + seeds - 1``; write per-seed rows and print a JSON summary."""
    from fftnav.episode.flight3d import FLIGHT_COLUMNS, FlightConfig, fly, summarize
    from fftnav.files import check_distinct, check_target, write_atomic

    if args.seeds < 1:
        raise FftnavError(f"--seeds must be an integer >= 1, got --seeds={args.seeds}")
    if args.first < 0:
        raise FftnavError(f"--first must be an integer >= 0, got --first={args.first}")
    seeds = range(args.first, args.first + args.seeds)
    if args.plot and args.plot_seed not in seeds:
        raise FftnavError(f"--plot-seed must be one of the flown seeds {seeds.start}.."
                          f"{seeds.stop - 1}, got --plot-seed={args.plot_seed}")
    config = FlightConfig(rows=args.rows, cols=args.cols)
    check_distinct({"--out": args.out, "--plot": args.plot})
    for flag in ("--out", "--plot"):  # refused before any flight
        if getattr(args, flag[2:]):
            check_target(getattr(args, flag[2:]), flag=flag, make_folder=True,
                         image=flag == "--plot")
    results = []
    try:
        for seed in seeds:
            results.append(fly(seed, config))
    finally:  # the flights finished are kept, also when a later one fails or is interrupted
        if results:
            text = io.StringIO()
            writer = csv.DictWriter(text, fieldnames=FLIGHT_COLUMNS)
            writer.writeheader()
            writer.writerows(r.row() for r in results)
            write_atomic(args.out, text.getvalue())
    if args.plot:
        from fftnav.report.depth3d import draw_flight_figure

        draw_flight_figure(results[seeds.index(args.plot_seed)], args.plot)  # atomically
    print(json.dumps(summarize(results)))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("fly3d", help="quadrotor flights through 3D forests (beyond the paper)")
    p.add_argument("--seeds", type=int, default=20, help="number of forests (default 20)")
    p.add_argument("--first", type=int, default=0, help="first seed, >= 0 (default 0)")
    p.add_argument("--out", required=True, metavar="CSV", help="per-seed results CSV")
    p.add_argument("--plot", metavar="PNG", help="also draw one flight (top and side views)")
    p.add_argument("--plot-seed", type=int, default=0,
                   help="seed drawn by --plot, one of the flown seeds (default 0)")
    p.add_argument("--rows", type=int, default=90, help="sensor elevation rows (default 90)")
    p.add_argument("--cols", type=int, default=360, help="sensor azimuth columns (default 360)")
    p.set_defaults(func=cmd_fly3d)
