"""How often collab's side rule decides (docs/history.md: why the map rule rarely decided at
walls, and the rule's revision).

Run from the repository root: ``.venv/bin/python experiments/collab_side_rule.py`` (the rule as it
is, about 1 min on 2 cores) or with ``--margin 2 --unknown-cost 1`` (the rule before its
revision: a 2 m margin, unseen cells as cheap as seen ones). Runs ``collab`` on walls maps of
the core comparison (``experiments/collab/core.toml``) and counts, over every call of the
shared-side rule (decisions and re-decisions when news arrived): the calls that chose a side,
those where no way existed or no neighbour's segment was about the obstacle ahead, and the
quantiles of the difference between the two ways.
"""

from __future__ import annotations

import argparse

import numpy as np

from fftnav.episode.loop import run_episode
from fftnav.navigation import bugcontrol
from fftnav.runner.config import load_config
from fftnav.runner.tasks import episode_seed, task_world


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", type=int, default=5, help="walls maps 1..MAPS (default 5)")
    parser.add_argument("--margin", type=float, default=bugcontrol.SIDE_MARGIN_M)
    parser.add_argument("--unknown-cost", type=float, default=bugcontrol.UNKNOWN_COST)
    args = parser.parse_args()
    bugcontrol.SIDE_MARGIN_M, bugcontrol.UNKNOWN_COST = args.margin, args.unknown_cost
    config = load_config("experiments/collab/core.toml")
    calls = chose = no_way = 0
    diffs: list[float] = []
    rule = bugcontrol.BugController._shared_side

    def counted(self: bugcontrol.BugController, i: int) -> int | None:
        nonlocal calls, chose, no_way
        side = rule(self, i)  # the costs again, to record them (the same map and field)
        left, right = self.planner.maps.side_costs(
            i, self.poses[i, :2], self.goals[i], radius_m=bugcontrol.SIDE_RADIUS_M,
            shared_only=True, unknown_cost=args.unknown_cost)
        calls, chose = calls + 1, chose + (side is not None)
        if min(left, right) == np.inf:
            no_way += 1
        else:
            diffs.append(abs(left - right))
        return side

    bugcontrol.BugController._shared_side = counted
    for m in range(1, args.maps + 1):
        run_episode(task_world(config, "walls", m), "collab", seed=episode_seed("walls", m),
                    config=config.swarm)
    q = np.quantile(diffs, [0.5, 0.75, 0.9]) if diffs else [np.nan] * 3
    print(f"margin {args.margin} m, unknown cost {args.unknown_cost}, walls maps 1-{args.maps}: "
          f"{calls} calls, {chose} chose a side ({100 * chose / max(calls, 1):.0f} %), "
          f"{no_way} without a way or a neighbour's segment; both ways in {len(diffs)}: "
          f"difference median {q[0]:.2f} m, 75th percentile {q[1]:.2f} m, 90th {q[2]:.2f} m, "
          f"{sum(d < args.margin for d in diffs)} below the margin")


if __name__ == "__main__":
    main()
