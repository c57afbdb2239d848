"""The reference training of docs/learning.md (``make learn``): every config of
experiments/learn/ (three controller observations and the decider) with three seeds each, then
the trained networks on Table I's maps beside the built-ins, and the report.

    python experiments/learn/reference.py [--workers 2] [--seeds 0 1 2] [--skip-training]

1. ``fftnav learn CONFIG --seed S --out results/learned/runs/<config>-s<S>`` for each config
   and seed, ``--workers`` at a time (each training runs one simulator and one torch thread);
   a rerun resumes unfinished trainings and skips finished ones. The wall-clock time of the
   whole, and of each training, goes to ``results/learned/reference_time.json``.
2. Per config, the seed with the best validation SPL gives ``results/learned/nets/``:
   ``ppo-<observation>.npz`` (its best checkpoint) and ``ppo-<observation>-untrained.npz``
   (the same network before training) for a controller, ``ppo.npz`` for the decider
   (``learned-decider:ppo.npz``, rows named ``learned-decider-ppo``).
3. ``fftnav run experiments/learned.toml`` (Table I's 40 maps: the learned methods and the
   untrained networks); the built-ins' rows on the same maps are ``results/table1``'s
   (``make benchmark``: the Bug baselines, ``fusion``, ``own-only``, ``random``).
4. ``fftnav figure learning`` -> ``results/learned/learning.md``, ``curves.png``,
   ``curves.csv``, ``training.csv``, ``paired_tests.csv``.

The training folders (checkpoints, per-run curves) stay out of git (``results/**/runs/``).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "experiments" / "learn"
OUT = ROOT / "results" / "learned"
FFTNAV = [sys.executable, "-m", "fftnav"]
#: The methods shown in the report, in order (the learned ones after the built-ins).
ORDER = ["bug-left", "bug-right", "random", "own-only", "fusion", "learned-decider-ppo",
         "learned-ppo-ranges", "learned-ppo-safe", "learned-ppo-extrema",
         "learned-ppo-ranges-untrained", "learned-ppo-safe-untrained",
         "learned-ppo-extrema-untrained"]
#: Validation AR whose first crossing the report gives, per observation.
THRESHOLD = 0.8


def _train(config: Path, seed: int) -> tuple[str, float]:
    out = OUT / "runs" / f"{config.stem}-s{seed}"
    start = time.perf_counter()
    if not (out / "run.json").exists():
        log = out.with_suffix(".log")
        log.parent.mkdir(parents=True, exist_ok=True)
        with open(log, "w") as fh:
            subprocess.run([*FFTNAV, "learn", str(config), "--seed", str(seed), "--out", str(out),
                            "--quiet"], check=True, stdout=fh, stderr=subprocess.STDOUT)
    return out.name, time.perf_counter() - start


def _best_seed(runs: list[Path]) -> Path:
    return max(runs, key=lambda r: (json.loads((r / "run.json").read_text())["best_spl"],
                                    -runs.index(r)))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--skip-training", action="store_true",
                    help="use the finished trainings in results/learned/runs")
    args = ap.parse_args(argv)
    configs = sorted(CONFIGS.glob("*.toml"))
    jobs = [(c, s) for c in configs for s in args.seeds]
    if not args.skip_training:
        start = time.perf_counter()
        with ThreadPoolExecutor(args.workers) as pool:
            times = dict(pool.map(lambda job: _train(*job), jobs))
        total = time.perf_counter() - start
        OUT.mkdir(parents=True, exist_ok=True)
        (OUT / "reference_time.json").write_text(json.dumps(
            {"workers": args.workers, "wall_s": round(total, 1),
             "runs": {k: round(v, 1) for k, v in times.items()}}, indent=1) + "\n")
        print(f"reference training: {len(jobs)} runs in {total / 60:.1f} min "
              f"with {args.workers} workers", flush=True)
    nets = OUT / "nets"
    nets.mkdir(parents=True, exist_ok=True)
    folders = []
    for config in configs:
        runs = [OUT / "runs" / f"{config.stem}-s{s}" for s in args.seeds]
        folders += runs
        best = _best_seed(runs)
        method = json.loads((best / "config.json").read_text())
        if method["method"] == "decider":
            shutil.copyfile(best / "best.npz", nets / "ppo.npz")
        else:
            obs = method["observation"]
            shutil.copyfile(best / "best.npz", nets / f"ppo-{obs}.npz")
            shutil.copyfile(best / "untrained.npz", nets / f"ppo-{obs}-untrained.npz")
        print(f"{config.stem}: best seed {best.name}", flush=True)
    # --fresh: the networks were just written (a folder of earlier ones is not resumed)
    subprocess.run([*FFTNAV, "run", str(ROOT / "experiments" / "learned.toml"), "--fresh",
                    "--workers", str(args.workers)], check=True)
    subprocess.run([*FFTNAV, "figure", "learning", *map(str, folders), "--table1",
                    str(OUT / "table1"), str(ROOT / "results" / "table1"), "--policies", *ORDER,
                    "--threshold", str(THRESHOLD), "--out", str(OUT)], check=True)


if __name__ == "__main__":
    main()
