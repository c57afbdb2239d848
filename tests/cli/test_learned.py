"""``fftnav episode --policy learned:PATH.npz`` (and ``learned-decider:PATH.npz``) as a
subprocess: it runs with numpy alone (torch, jax, the RL libraries and Gymnasium/PettingZoo made
unimportable), records, and refuses a bad file in one line."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from fftnav.navigation.learned import untrained
from fftnav.navigation.learned_decider import untrained_decider
from fftnav.world import World, save_world

UP = math.pi / 2
# A meta-path finder that refuses the learning libraries, installed before fftnav starts.
BLOCK = """
import sys
class _Refuse:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {"torch", "jax", "jaxlib", "flax", "stable_baselines3", "skrl",
                                  "torchrl", "tensordict", "supersuit", "gymnasium",
                                  "pettingzoo"}:
            raise ImportError(f"{name} is blocked by the test")
        return None
sys.meta_path.insert(0, _Refuse())
import runpy
sys.argv = ["fftnav", *sys.argv[1:]]
runpy.run_module("fftnav", run_name="__main__")
"""


def fftnav(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", BLOCK, *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


def _files(tmp_path: Path) -> None:
    world = World("test", 0, (6.0, 8.0), (), np.array([[1, 1, UP], [4, 1, UP]], float),
                  np.array([[1, 7], [4, 7]], float))
    save_world(world, tmp_path / "w.json")
    untrained("extrema", seed=0, hidden=(8,)).save(tmp_path / "net.npz")


def test_episode_runs_a_learned_net_without_torch_or_jax(tmp_path):
    _files(tmp_path)
    proc = fftnav("episode", "--world", "w.json", "--policy", "learned:net.npz", "--out", "e.csv",
                  "--record", "r.npz", "--set", "time_limit_s=1", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = pd.read_csv(tmp_path / "e.csv")
    assert rows.policy.tolist() == ["learned-net", "learned-net"]
    assert (tmp_path / "r.npz").stat().st_size > 0
    untrained_decider(0).save(tmp_path / "d.npz")
    proc = fftnav("episode", "--world", "w.json", "--policy", "learned-decider:d.npz", "--out",
                  "d.csv", "--set", "time_limit_s=1", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert pd.read_csv(tmp_path / "d.csv").policy.tolist() == ["learned-decider-d"] * 2
    # the prelude does block them
    blocked = subprocess.run([sys.executable, "-c", BLOCK.split("import runpy")[0]
                              + "import torch"], capture_output=True, text=True)
    assert blocked.returncode == 1 and "torch is blocked by the test" in blocked.stderr


def test_a_bad_weights_file_is_refused_in_one_line(tmp_path):
    _files(tmp_path)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    for ref, match in (("learned:junk.npz", "junk.npz"), ("learned:none.npz", "no such file")):
        proc = fftnav("episode", "--world", "w.json", "--policy", ref, cwd=tmp_path)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.count("\n") == 1 and match in proc.stderr
        assert "Traceback" not in proc.stderr
