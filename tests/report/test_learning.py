"""The learned methods' report: curves over seeds, samples to the AR threshold, and the paired
tests of per-map SPL, checked against scipy on constructed results."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from fftnav.report.learning import (
    comparison_pairs,
    paired_rows,
    read_curves,
    steps_to_ar,
    write_learning_report,
)


def _run(folder, *, method="controller", observation="extrema", seed=0, ar=(0, 0.5, 0.9)):
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps({"method": method, "observation": observation,
                                                    "seed": seed}))
    n = len(ar)
    curve = pd.DataFrame({"samples": np.arange(n) * 1000, "live_steps": np.arange(n) * 500,
                          "episodes": np.arange(n), "wall_s": np.arange(n) * 10.0,
                          "train_ar": np.linspace(0, 1, n), "val_ar": ar,
                          "val_spl": np.array(ar) * 0.9, "val_collided": 0.0,
                          "val_timed_out": 1 - np.array(ar), "val_robots": 30})
    curve.to_csv(folder / "curve.csv", index=False)
    (folder / "run.json").write_text(json.dumps({"samples": int((n - 1) * 1000),
                                                 "wall_s": 10.0 * n}))
    return folder


def test_samples_to_the_threshold_is_the_first_validation_reaching_it(tmp_path):
    runs = [_run(tmp_path / "a", ar=(0, 0.5, 0.9, 0.7)), _run(tmp_path / "b", seed=1,
                                                               ar=(0, 0.85, 0.9, 0.95)),
            _run(tmp_path / "c", seed=2, ar=(0, 0.1, 0.2, 0.3))]
    curves = read_curves(runs)
    reach = steps_to_ar(curves, 0.8)
    assert reach["a"] == 2000 and reach["b"] == 1000 and math.isnan(reach["c"])
    assert list(curves.columns[:3]) == ["run", "group", "seed"]
    assert set(curves["group"]) == {"controller/extrema"}


def _episodes(rng, policies, maps=12):
    rows = []
    for env in ("forest", "rocky"):
        for m in range(maps):
            for policy, level in policies.items():
                for robot in range(3):
                    spl = float(np.clip(level + rng.normal(0, 0.1), 0, 1))
                    arrived = spl > 0.2
                    rows.append({"env": env, "map_seed": 1000 + m, "policy": policy,
                                 "robot": robot, "arrived": arrived, "spl": spl if arrived else 0,
                                 "path_length_m": 20.0, "failure": "" if arrived else "collision"})
    return pd.DataFrame(rows)


def test_paired_rows_are_scipys_wilcoxon_per_env_and_pooled():
    rng = np.random.default_rng(0)
    episodes = _episodes(rng, {"random": 0.8, "learned-decider-d": 0.9, "learned-a": 0.6,
                               "learned-a-untrained": 0.1})
    pairs = comparison_pairs(list(episodes["policy"].unique()))
    assert pairs == [("learned-a", "learned-a-untrained"), ("learned-decider-d", "random")]
    table = paired_rows(episodes, pairs)
    assert list(table["env"]) == ["forest", "rocky", "all"] * 2
    per_map = episodes.pivot_table(index=["env", "map_seed"], columns="policy", values="spl")
    for row in table.itertuples():
        sub = per_map if row.env == "all" else per_map.xs(row.env, level="env")
        diff = (sub[row.method] - sub[row.against]).to_numpy()
        assert row.maps == len(diff)
        assert row.gain == pytest.approx(diff.mean())
        expected = stats.wilcoxon(diff, method="exact" if len(diff) <= 20 else "auto").pvalue
        assert row.p_value == pytest.approx(expected, rel=1e-9)


def test_the_report_lists_runs_methods_failures_and_tests(tmp_path):
    runs = [_run(tmp_path / f"e{s}", seed=s, ar=(0, 0.5 + 0.1 * s, 0.9)) for s in range(3)]
    runs.append(_run(tmp_path / "dec", method="decider", observation=None, ar=(1, 1)))
    rng = np.random.default_rng(1)
    table1 = tmp_path / "table1"
    table1.mkdir()
    _episodes(rng, {"random": 0.8, "learned-decider-d": 0.9, "learned-e": 0.5,
                    "learned-e-untrained": 0.0}).to_csv(table1 / "episodes.csv", index=False)
    report = write_learning_report(runs, tmp_path / "out", table1=table1, threshold=0.8,
                                   order=["random", "learned-decider-d", "learned-e",
                                          "learned-e-untrained"])
    text = report.read_text()
    assert "| controller/extrema | 3 | 2,000 [2,000, 2,000] | 90.0 [90.0, 90.0] |" in text
    assert "| decider | 1 | 0 | 100.0 | 90.0 | 90.0 |" in text
    assert "| learned-e-untrained | forest | 2.8 | 0.6 | 20.00 | collision 35 |" in text
    assert "| learned-decider-d | random | all | 24 |" in text
    for name in ("curves.csv", "training.csv", "curves.png", "paired_tests.csv"):
        assert (tmp_path / "out" / name).stat().st_size > 0
    training = pd.read_csv(tmp_path / "out" / "training.csv")
    assert list(training["samples_to_ar"]) == [2000, 2000, 2000, 0]


def test_the_table1_rows_may_come_from_several_folders_each_method_once(tmp_path):
    rng = np.random.default_rng(2)
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    _episodes(rng, {"learned-e": 0.5, "learned-e-untrained": 0.0}).to_csv(a / "episodes.csv",
                                                                          index=False)
    _episodes(rng, {"random": 0.8, "fusion": 0.9}).to_csv(b / "episodes.csv", index=False)
    runs = [_run(tmp_path / "r0")]
    report = write_learning_report(runs, tmp_path / "out", table1=[a, b], threshold=0.5)
    text = report.read_text()
    assert f"rows of `{a}`, `{b}`" in text
    assert "| fusion | forest |" in text and "| learned-e | learned-e-untrained | all | 24 |" in text
    _episodes(rng, {"random": 0.7}).to_csv(a / "episodes.csv", index=False)
    with pytest.raises(ValueError, match=r"policy 'random' is in both .*a and .*b; give each "
                                         r"method's rows once"):
        write_learning_report(runs, tmp_path / "out", table1=[a, b], threshold=0.5)
