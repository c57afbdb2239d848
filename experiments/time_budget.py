"""Where the failing robots' time went: driving, correcting the heading, turning, standing.

A robot that does not arrive at walls and traps has usually not gone far out of its way: it
ran out of the 120 s. This script reads the recordings an experiment keeps (by default those of
the episodes in which a robot failed; :mod:`fftnav.episode.recording`) and splits every moving
robot's control ticks with :func:`fftnav.metrics.motions`: driving (``v != 0``), correcting its
heading (rotating in place one way for less than 1 s), turning (one way for 1 s or more, as to
go back) and standing, overall and by the planner's state at the tick (the controller's
``state/mode``, a :class:`fftnav.states.State` code: heading for the goal, following a boundary,
escaping, guided, waiting for the robots in its way). It also counts
the *swings*: rotating ticks that reverse the rotation of the tick before (a robot swinging
left and right on the spot). Robots that failed and robots that arrived in the same episodes
are counted apart.

It also gives, from ``FOLDER/episodes.csv``, the AR each env and policy would have had at
shorter time limits than the run's (a robot arrived by T if its arrival time is at most T; the
episodes are the same up to T). ``experiments/collab/fresh_noise_240.toml`` runs the fresh
walls and traps maps with 240 s for this: are the robots that fail at 120 s trapped, or slow?

Run from the repository root: ``python experiments/time_budget.py [FOLDER]`` (default
``results/collab/fresh``; a few seconds) -> ``FOLDER/time_budget.csv`` (one row per robot of
each recorded episode: seconds moving, driving, correcting, turning and standing, the turns,
the distance left to its goal, and the seconds and rotating seconds in each state) and
``FOLDER/time_budget.md`` (the shares per env, policy and outcome, and by state; the AR by
time limit).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from fftnav.episode.recording import read_recording
from fftnav.metrics import MOTIONS, motions
from fftnav.states import State, Status

ROOT = Path(__file__).resolve().parents[1]
#: The planner's states a moving robot is in (``state/mode``), by code.
MODES = {int(s): s.label for s in (State.GOAL, State.FOLLOW, State.ESCAPE, State.GUIDED,
                                  State.WAIT)}
TURN_S = 1.0
#: Time limits (s) of the AR table, up to the run's own.
LIMITS_S = (60.0, 90.0, 120.0, 150.0, 180.0, 210.0, 240.0)


def budget(path: Path) -> list[dict]:
    """One row per robot of the recording at ``path``: where its moving ticks went."""
    rec = read_recording(path)
    dt = 1.0 / rec.config.episode.control_hz
    moving = rec.status[:-1] == Status.MOVING  # the last tick has no command
    kinds = motions(rec.command[:-1], moving, control_hz=rec.config.episode.control_hz,
                    turn_s=TURN_S)
    mode = rec.state["mode"][:-1]
    turn = MOTIONS.index("turn")
    rotating = np.isin(kinds, (MOTIONS.index("correct"), turn))
    w = np.sign(rec.command[:-1, :, 1])
    swing = np.zeros_like(rotating)
    swing[1:] = rotating[1:] & rotating[:-1] & (w[1:] == -w[:-1])
    rows = []
    for i, row in enumerate(rec.rows):
        k = kinds[:, i]
        starts = np.flatnonzero((k == turn) & ((np.r_[-1, k[:-1]] != turn) | swing[:, i]))
        out = {"env": rec.world.env, "map_seed": rec.world.seed, "policy": rec.policy,
               "robot": i, "arrived": bool(row["arrived"]), "failure": row["failure"],
               "moving_s": float((k >= 0).sum() * dt), "turns": len(starts),
               "swing_s": float(swing[:, i].sum() * dt),
               "goal_left_m": float(np.hypot(*(rec.pose[-1, i, :2] - rec.world.goals[i])))}
        for j, name in enumerate(MOTIONS):
            out[f"{name}_s"] = float((k == j).sum() * dt)
        for code, name in MODES.items():
            here = (k >= 0) & (mode[:, i] == code)
            out[f"{name}_s"] = float(here.sum() * dt)
            out[f"{name}_rotating_s"] = float((here & rotating[:, i]).sum() * dt)
        rows.append(out)
    return rows


def _pct(part: pd.Series, whole: pd.Series) -> str:
    return f"{100 * part.sum() / max(whole.sum(), 1e-9):.0f}"


def _title(folder: Path) -> str:
    name = folder.resolve().relative_to(ROOT) if folder.resolve().is_relative_to(ROOT) else folder
    return f"# Where the time went: `{name}`\n"


def report(table: pd.DataFrame, folder: Path) -> str:
    """The shares of moving time, per env, policy and outcome, and by the planner's state."""
    lines = [_title(folder),
             "Written by `python experiments/time_budget.py` from the recordings the experiment "
             "kept (the episodes in which a robot did not arrive), with "
             f"`fftnav.metrics.motions` (a turn: rotating in place one way for at least "
             f"{TURN_S:g} s; a correction: less). Shares in % of the robots' moving time; "
             "swing: the rotating ticks that reverse the tick before's rotation (part of the "
             "corrections); turns and seconds per robot.", "",
             "| env | policy | outcome | robots | moving s | drive | correct | turn | stand "
             "| swing | turns | goal left m |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (env, policy, arrived), g in table.groupby(["env", "policy", "arrived"]):
        lines.append(
            f"| {env} | {policy} | {'arrived' if arrived else 'failed'} | {len(g)} "
            f"| {g.moving_s.mean():.1f} | {_pct(g.drive_s, g.moving_s)} "
            f"| {_pct(g.correct_s, g.moving_s)} | {_pct(g.turn_s, g.moving_s)} "
            f"| {_pct(g.stand_s, g.moving_s)} | {_pct(g.swing_s, g.moving_s)} "
            f"| {g.turns.mean():.1f} "
            f"| {g.goal_left_m.mean() if not arrived else float('nan'):.1f} |")
    lines += ["", "By the planner's state, every policy together: the share of the moving "
              "time spent in the state, and within it the share spent rotating in place.", "",
              "| env | outcome | " + " | ".join(MODES.values()) + " |",
              "|---|---|" + "---|" * len(MODES)]
    for (env, arrived), g in table.groupby(["env", "arrived"]):
        cells = [f"{_pct(g[f'{m}_s'], g.moving_s)} ({_pct(g[f'{m}_rotating_s'], g[f'{m}_s'])})"
                 for m in MODES.values()]
        lines.append(f"| {env} | {'arrived' if arrived else 'failed'} | " + " | ".join(cells)
                     + " |")
    return "\n".join(lines) + "\n"


def by_limit(episodes: pd.DataFrame, limit_s: float) -> str:
    """AR % (failures) per env and policy at each of LIMITS_S up to ``limit_s``."""
    limits = [t for t in LIMITS_S if t <= limit_s + 1e-9]
    lines = [f"## AR by time limit (the run's: {limit_s:g} s)", "",
             "From `episodes.csv`: a robot counts as arrived by T if it arrived at most T s "
             "after its departure. AR % (failures).", "",
             "| env | policy | " + " | ".join(f"{t:g} s" for t in limits) + " |",
             "|---|---|" + "---|" * len(limits)]
    for (env, policy), g in episodes.groupby(["env", "policy"]):
        t = g.time_s.where(g.arrived.astype(bool), np.inf).to_numpy()
        cells = [f"{100 * (t <= lim).mean():.1f} ({int((t > lim).sum())})" for lim in limits]
        lines.append(f"| {env} | {policy} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    folder = Path(argv[0]) if argv else ROOT / "results" / "collab" / "fresh"
    paths = sorted((folder / "records").glob("*.npz"))
    if not paths and not (folder / "episodes.csv").is_file():
        print(f"time_budget: no recordings and no episodes.csv in {folder}", file=sys.stderr)
        return 2
    text = ""
    if paths:
        table = pd.DataFrame([r for p in paths for r in budget(p)])
        table.round(3).to_csv(folder / "time_budget.csv", index=False)
        text = report(table, folder)
    if (folder / "episodes.csv").is_file():
        limit_s = json.loads((folder / "config.json").read_text())["swarm"]["episode"][
            "time_limit_s"]
        text += ("\n" if text else _title(folder) + "\n") + by_limit(
            pd.read_csv(folder / "episodes.csv"), limit_s)
    (folder / "time_budget.md").write_text(text)
    print(f"{len(paths)} recordings -> {folder / 'time_budget.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
