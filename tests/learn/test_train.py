"""fftnav learn end to end, when the extra `learn` (Stable-Baselines3, torch) is installed: a
smoke training of each method, its exported network equal to the library's policy, resuming
equal to an uninterrupted run, and the CLI."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

sb3 = pytest.importorskip("stable_baselines3", reason="the optional extra fftnav[learn] is "
                          "not installed")
torch = pytest.importorskip("torch")

from fftnav.learn import parse_learn_config  # noqa: E402
from fftnav.learn.train import CURVE_COLUMNS, _Run, export_policy, train  # noqa: E402
from fftnav.navigation.learned_decider import decider_logit  # noqa: E402
from fftnav.navigation.mlp import MLP  # noqa: E402

SMOKE = {"learn": {"observation": "extrema", "agent_steps": 384, "robots": 3},
         "ppo": {"n_steps": 32, "batch_size": 48, "n_epochs": 2},
         "action": {"v_range": [0.0, 1.0]},
         "train": {"map_seeds": [5000, 5100], "min_live": 0.34},
         "validation": {"map_seeds": [7000, 7100], "every": 192, "episodes": 1},
         "episode": {"time_limit_s": 8}}
DECIDER = {"learn": {"method": "decider", "agent_steps": 64, "robots": 6, "warmup": 16},
           "ppo": {"n_steps": 32, "batch_size": 16, "n_epochs": 2},
           "train": {"worlds": ["rocky"], "map_seeds": [5000, 5100]},
           "validation": {"worlds": ["rocky"], "map_seeds": [7000, 7100], "every": 32,
                          "episodes": 1},
           "episode": {"time_limit_s": 30}}


def _config(base, **learn):
    data = json.loads(json.dumps(base))
    data["learn"].update(learn)
    return parse_learn_config(data)


def _curve(path):
    """curve.csv without its wall-clock column."""
    lines = path.read_text().splitlines()
    drop = CURVE_COLUMNS.index("wall_s")
    return [",".join(v for i, v in enumerate(line.split(",")) if i != drop) for line in lines]


def test_a_smoke_training_of_each_method_within_60_s(tmp_path):
    start = time.perf_counter()
    outcome = train(_config(SMOKE), tmp_path / "c")
    decider = train(_config(DECIDER), tmp_path / "d")
    assert time.perf_counter() - start < 60
    for result, kind in ((outcome, "controller"), (decider, "decider")):
        folder = result.out
        names = {p.name for p in folder.iterdir()}
        assert {"config.json", "curve.csv", "best.npz", "policy.npz", "checkpoint", "run.json",
                "validation_maps.json"} <= names
        curve = (folder / "curve.csv").read_text().splitlines()
        assert curve[0] == ",".join(CURVE_COLUMNS)
        assert len(curve) >= 3  # the untrained network, then one row per validation
        net = MLP.load(folder / "best.npz")
        assert net.meta["kind"] == kind
    assert outcome.samples >= 384 and decider.samples >= 64


def test_the_exported_network_is_the_librarys_policy_to_1e_5(tmp_path):
    for base in (SMOKE, DECIDER):
        config = _config(base)
        run = _Run(config, tmp_path)
        try:
            run.model.learn(64)
            net = export_policy(run.model, config, run.standardisation())
            policy = run.model.policy
            rng = np.random.default_rng(0)
            x = rng.normal(size=(50, net.n_in)).astype(np.float32)
            with torch.no_grad():
                dist = policy.get_distribution(torch.as_tensor(x))
                if config.method == "controller":
                    expected = dist.distribution.mean.numpy()
                    got = net(x)
                    # and the action SB3 takes deterministically, clipped to [-1, 1]
                    actions, _ = run.model.predict(x, deterministic=True)
                    np.testing.assert_allclose(np.clip(got, -1, 1), actions, atol=1e-5)
                else:
                    logits = dist.distribution.logits.numpy()
                    expected = (logits[:, 1] - logits[:, 0])[:, None]
                    mean, std = run.standardisation()
                    # the learned decider standardises the raw features with the file's meta
                    got = np.array([[decider_logit(net, f)] for f in x * std + mean])
                    sides, _ = run.model.predict(x, deterministic=True)
                    np.testing.assert_array_equal(sides, (got[:, 0] > 0).astype(int))
            np.testing.assert_allclose(got, expected, atol=1e-5)
        finally:
            run.close()


def test_resuming_gives_the_uninterrupted_runs_curve_and_weights(tmp_path):
    train(_config(SMOKE), tmp_path / "straight")
    train(_config(SMOKE, agent_steps=192), tmp_path / "resumed")
    train(_config(SMOKE), tmp_path / "resumed")  # a larger budget resumes the folder
    assert _curve(tmp_path / "straight" / "curve.csv") == _curve(tmp_path / "resumed" / "curve.csv")
    a, b = MLP.load(tmp_path / "straight" / "policy.npz"), MLP.load(tmp_path / "resumed" / "policy.npz")
    assert a == b


def test_another_config_for_the_same_folder_is_refused(tmp_path):
    train(_config(SMOKE, agent_steps=192), tmp_path / "r")
    with pytest.raises(ValueError, match=r"holds a training of another config"):
        train(_config(SMOKE, seed=1), tmp_path / "r")
    outcome = train(_config(SMOKE, seed=1, agent_steps=192), tmp_path / "r", fresh=True)
    assert json.loads((tmp_path / "r" / "config.json").read_text())["seed"] == 1
    assert outcome.samples >= 192


def test_cli_learn_trains_and_reports(tmp_path):
    config = tmp_path / "smoke.toml"
    config.write_text(
        '[learn]\nobservation = "extrema"\nagent_steps = 96\nrobots = 3\n'
        '[ppo]\nn_steps = 32\nbatch_size = 48\nn_epochs = 1\n'
        '[train]\nmap_seeds = [5000, 5100]\n'
        '[validation]\nmap_seeds = [7000, 7100]\nevery = 96\nepisodes = 1\n'
        '[episode]\ntime_limit_s = 5\n')
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "fftnav", "learn", str(config), "--out", str(out),
                          "--quiet"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "best validation SPL" in res.stdout and (out / "best.npz").exists()
    bad = tmp_path / "bad.toml"
    bad.write_text('[learn]\nobservation = "lidar"\n')
    res = subprocess.run([sys.executable, "-m", "fftnav", "learn", str(bad)],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "learn.observation must be one of" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
