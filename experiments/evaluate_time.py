"""How long `fftnav evaluate` takes beside `make benchmark`, measured side by side in one
invocation on the same machine: the README's controller (`my_controller.py:SafeGreedy`)
evaluated on `paper-v2` (its 40 episodes, the reference check's 2 episodes, the ranking), then
`make benchmark`'s run (`fftnav run experiments/table1.toml`: 5 methods x 40 maps), each from
scratch in a temporary folder with 2 workers. Writes results/evaluate_time.csv (wall seconds
and their ratio) and what `fftnav evaluate` printed, results/evaluate_safe_greedy.txt.
Run: `make evaluate-time` (about 6 minutes on 2 cores)."""

from __future__ import annotations

import csv
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FFTNAV = [sys.executable, "-m", "fftnav"]


def _timed(args: list[str], cwd: Path) -> tuple[float, str]:
    """Wall seconds of a command, and what it printed."""
    begin = time.perf_counter()
    done = subprocess.run(args, cwd=cwd, check=True, stdout=subprocess.PIPE, text=True)
    return time.perf_counter() - begin, done.stdout


def main() -> None:
    section = re.search(r"## Benchmark your own method\n(.*?)\n## ",
                        (ROOT / "README.md").read_text(), re.S).group(1)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        (work / "my_controller.py").write_text(re.search(r"```python\n(.*?)```", section,
                                                         re.S)[1])
        evaluate, printed = _timed([*FFTNAV, "evaluate", "my_controller.py:SafeGreedy", "--suite",
                           "paper-v2", "--out", "ev", "--workers", "2", "--quiet"], work)
        benchmark, _ = _timed([*FFTNAV, "run", str(ROOT / "experiments" / "table1.toml"), "--out",
                            "table1", "--workers", "2", "--quiet"], work)
    rows = [("fftnav evaluate my_controller.py:SafeGreedy --suite paper-v2", 42,
             round(evaluate, 1)),
            ("make benchmark (fftnav run experiments/table1.toml)", 200, round(benchmark, 1))]
    out = ROOT / "results" / "evaluate_time.csv"
    with out.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["command", "episodes", "wall_s", "ratio_to_benchmark"])
        for command, episodes, wall in rows:
            writer.writerow([command, episodes, wall, round(wall / benchmark, 3)])
    (ROOT / "results" / "evaluate_safe_greedy.txt").write_text(
        printed.replace(str(work), "TMP"))
    print(out.read_text(), end="")


if __name__ == "__main__":
    main()
