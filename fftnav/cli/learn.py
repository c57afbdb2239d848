"""``fftnav learn CONFIG [--seed N] [--agent-steps N] [--out DIR] [--fresh] [--quiet]``:
train a learned controller or decider with PPO (:mod:`fftnav.learn.train`, the extra
``learn``); rerunning resumes."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def cmd_learn(args: argparse.Namespace) -> int:
    """Train CONFIG into DIR with a progress bar (learner samples, samples/s, running AR);
    130/143 when interrupted (the last checkpoint stays; rerun the same command to resume)."""
    import dataclasses

    from fftnav.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, CliError, Terminated
    from fftnav.learn import load_learn_config
    from fftnav.learn.progress import ProgressBar
    from fftnav.learn.train import check_extra, train

    config = load_learn_config(args.config)
    if args.seed is not None:
        if args.seed < 0:
            raise CliError(f"--seed must be an integer >= 0, got --seed={args.seed}")
        config = dataclasses.replace(config, seed=args.seed)
    if args.agent_steps is not None:
        if args.agent_steps < 1:
            raise CliError(f"--agent-steps must be an integer >= 1, got "
                             f"--agent-steps={args.agent_steps}")
        config = dataclasses.replace(config, agent_steps=args.agent_steps)
    out = Path(args.out or Path("learned") / f"{Path(args.config).stem}-s{config.seed}")
    check_extra()
    bar = None if args.quiet else ProgressBar(config.agent_steps, desc=out.name)
    try:
        outcome = train(config, out, fresh=args.fresh, progress=bar)
    except (KeyboardInterrupt, Terminated) as exc:
        term = isinstance(exc, Terminated)
        if bar is not None:
            bar.close()
        sys.stderr.write(f"fftnav learn: {'terminated' if term else 'interrupted'}; the last "
                         f"checkpoint is kept in {out}, rerun the same command to resume\n")
        return EXIT_TERMINATED if term else EXIT_INTERRUPTED
    if bar is not None:
        bar.close()
    print(f"fftnav learn: {outcome.samples} samples in {outcome.wall_s:.0f} s; best validation "
          f"SPL {outcome.best_spl:.3f} at {outcome.best_samples} samples: {out / 'best.npz'}; "
          f"curve: {out / 'curve.csv'}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("learn", help="train a learned controller or decider with PPO "
                       "(extra fftnav[learn]; docs/learning.md)")
    p.add_argument("config", metavar="CONFIG", help="training TOML (experiments/learn/*.toml)")
    p.add_argument("--seed", type=int, metavar="N",
                   help="the training's seed, instead of the config's [learn] seed")
    p.add_argument("--agent-steps", type=int, metavar="N",
                   help="the budget in learner samples, instead of the config's (a larger one "
                   "trains a finished folder on)")
    p.add_argument("--out", metavar="DIR", help="output folder (default: "
                   "learned/<config stem>-s<seed>); a rerun resumes it")
    p.add_argument("--fresh", action="store_true",
                   help="start again, removing an earlier training of this folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_learn)
