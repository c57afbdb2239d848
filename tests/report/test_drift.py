"""The drift report against hand-made episodes: per-map sums, the summary's means, the paired
gains and their Holm adjustment, the figure, and the rebuild from drift_maps.csv alone."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fftnav.errors import FftnavError
from fftnav.report.drift import drift_gains, drift_maps, drift_summary, write_drift_report
from fftnav.runner import load_config
from fftnav.runner.summary import holm


def _episodes(rng):
    """Two policies on 8 maps at two drifts, 3 robots each: own-only always arrives with SPL
    0.9; collab too at drift none, and loses one robot per map at typical drift."""
    rows = []
    for drift in ("none", "typical"):
        for m in range(8):
            for policy in ("own-only", "collab"):
                for robot in range(3):
                    lost = policy == "collab" and drift == "typical" and robot == 0
                    spl = 0.0 if lost else 0.9 + (0.05 if policy == "collab" else 0.0)
                    rows.append({"env": "walls", "map_seed": 61 + m, "policy": policy,
                                 "robot": robot, "drift": drift, "arrived": not lost,
                                 "spl": spl, "path_length_m": 10.0 + rng.random(),
                                 "optimal_length_m": 9.0, "failure": "lost" if lost else ""})
    return pd.DataFrame(rows)


def test_sums_summary_and_gains_follow_the_episodes():
    episodes = _episodes(np.random.default_rng(0))
    maps = drift_maps(episodes)
    assert len(maps) == 2 * 8 * 2 and (maps["robots"] == 3).all()
    summary = drift_summary(maps, policies=["own-only", "collab"]).set_index(["policy", "drift"])
    assert summary.loc[("collab", "typical"), "ar"] == pytest.approx(2 / 3)
    assert summary.loc[("collab", "typical"), "ar_believed"] == 1.0
    assert summary.loc[("collab", "typical"), "lost"] == pytest.approx(1 / 3)
    assert summary.loc[("collab", "none"), "spl"] == pytest.approx(0.95)
    # the believed SPL of a lost robot: optimal / max(optimal, path), as for an arrived one
    mine = episodes[(episodes["policy"] == "collab") & (episodes["drift"] == "typical")]
    expected = (9.0 / mine["path_length_m"]).mean()
    assert summary.loc[("collab", "typical"), "spl_believed"] == pytest.approx(expected)
    gains = drift_gains(maps).set_index(["policy", "reference", "drift"])
    none = gains.loc[("collab", "own-only", "none")]
    typical = gains.loc[("collab", "own-only", "typical")]
    # eight maps all in favour: the exact two-sided Wilcoxon p is 2 / 2^8
    assert none["gain"] == pytest.approx(0.05) and none["p_value"] == pytest.approx(2 / 256)
    assert typical["gain"] == pytest.approx((2 * 0.95) / 3 - 0.9)
    assert typical["p_holm"] == pytest.approx(holm(gains["p_value"].to_numpy())[
        list(gains.index).index(("collab", "own-only", "typical"))])
    assert typical["verdict"] == "costs" and not typical["noninferior"]
    assert none["noninferior"]  # 5 points ahead on every map


def test_the_report_is_rebuilt_from_drift_maps_alone(tmp_path):
    config = load_config("experiments/drift/fresh.toml")
    with pytest.raises(FftnavError, match=r"results must hold the episodes.csv of experiment "
                                          r"'drift-fresh', cell 'base'"):
        write_drift_report([config], [tmp_path / "none"], tmp_path / "out")
    out = tmp_path / "out"
    out.mkdir()
    drift_maps(_episodes(np.random.default_rng(1))).to_csv(out / "drift_maps.csv", index=False)
    path = write_drift_report([config], [tmp_path / "none"], out)
    text = path.read_text()
    assert "| collab | own-only | walls | typical | 8 |" in text
    assert (out / "drift.png").stat().st_size > 10_000
    assert set(pd.read_csv(out / "drift_summary.csv")["drift"]) == {"none", "typical"}


def test_the_command_refuses_missing_results_in_one_line(tmp_path):
    config = Path("experiments/drift/fresh.toml").resolve()
    proc = subprocess.run([sys.executable, "-m", "fftnav", "figure", "drift", str(config),
                           "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, cwd=tmp_path)  # no results there
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "episodes.csv" in proc.stderr


def _maps(rows):
    """drift_maps.csv rows of (drift, policy, map_seed, mean SPL) on walls, 3 robots a map,
    all arrived."""
    return pd.DataFrame([{"env": "walls", "policy": policy, "drift": drift, "map_seed": m,
                          "robots": 3, "arrived": 3, "spl": 3 * spl, "believed": 3,
                          "spl_believed": 3 * spl, "lost": 0}
                         for drift, policy, m, spl in rows])


def _hand_maps():
    """At drift none, 24 maps: collab ahead of own-only by 1, 1, 2, 2, ..., 12, 12 units of
    1/128 (24 differences tied in pairs), fusion equal to own-only, bug-left 2 units behind
    it on every map; with exact poses, 8 maps: fusion ahead of own-only by 1, 2, ..., 8 units,
    no bug-left. Multiples of 1/128, so that the differences tie exactly."""
    own = {m: 0.25 + m / 128 for m in range(24)}
    rows = [("none", "own-only", m, v) for m, v in own.items()]
    rows += [("none", "collab", m, v + (1 + m // 2) / 128) for m, v in own.items()]
    rows += [("none", "fusion", m, v) for m, v in own.items()]
    rows += [("none", "bug-left", m, v - 2 / 128) for m, v in own.items()]
    rows += [("exact", "own-only", m, own[m]) for m in range(8)]
    rows += [("exact", "fusion", m, own[m] + (m + 1) / 128) for m in range(8)]
    return _maps(rows)


def _normal_p(plus, n, ties):
    """The normal approximation's p of a signed-rank sum ``plus`` of ``n`` ranks (scipy's
    default: no continuity correction) with tie groups of the sizes ``ties``, one-sided
    (H1: above the mean)."""
    from scipy import stats

    variance = n * (n + 1) * (2 * n + 1) / 24 - sum(t**3 - t for t in ties) / 48
    return stats.norm.sf((plus - n * (n + 1) / 4) / np.sqrt(variance))


def test_each_p_of_the_gains_says_how_it_was_computed():
    gains = drift_gains(_hand_maps()).set_index(["policy", "reference", "drift"])
    collab = gains.loc[("collab", "own-only", "none")]
    # 24 differences > 20, tied: the normal approximation, rank sum 300 of 300
    assert collab["p_method"] == collab["p_noninferior_method"] == "normal approx."
    assert collab["p_value"] == pytest.approx(2 * _normal_p(300, 24, [2] * 12), rel=1e-9)
    assert collab["p_noninferior"] == pytest.approx(_normal_p(300, 24, [2] * 12), rel=1e-9)
    same = gains.loc[("fusion", "own-only", "none")]
    # every difference 0: no two-sided test; shifted by the margin, 24 equal differences
    assert np.isnan(same["p_value"]) and same["p_method"] == ""
    assert same["p_noninferior_method"] == "normal approx."
    assert same["p_noninferior"] == pytest.approx(_normal_p(300, 24, [24]), rel=1e-9)
    exact = gains.loc[("fusion", "own-only", "exact")]
    # 8 distinct positive differences: exact, 1 of the 2^8 sign assignments each way
    assert exact["p_method"] == exact["p_noninferior_method"] == "exact"
    assert exact["p_value"] == 2 / 256 and exact["p_noninferior"] == 1 / 256
    absent = gains.loc[("fusion", "bug-left", "exact")]
    assert absent["maps"] == 0 and absent["p_method"] == "" and np.isnan(absent["gain"])


def _legend_of(lines, after):
    """The marks of the first legend line after the line ``after`` -> their reasons."""
    start = lines.index(after)
    line = next(x for x in lines[start:] if x.startswith("`-¹` "))
    return dict(re.findall(r"`(-[¹²³⁴⁵⁶⁷⁸⁹⁰]+)` (.*?)(?:; (?=`-)|\.$)", line))


def test_every_missing_number_of_the_drift_report_says_why(tmp_path):
    config = load_config("experiments/drift/fresh.toml")
    out = tmp_path / "out"
    out.mkdir()
    _hand_maps().to_csv(out / "drift_maps.csv", index=False)
    lines = write_drift_report([config], [tmp_path / "none"], out).read_text().splitlines()
    assert not any(re.search(r"\| +\|", x) for x in lines)  # no empty cell
    spl = _legend_of(lines, "## SPL (%)")
    row = next(x for x in lines if x.startswith("| bug-left | "))
    exact_cell, none_cell = (c.strip() for c in row.strip("|").split("|")[1:])
    assert spl[exact_cell] == ("no run with exact localization of this policy on these maps "
                               "(`--exact` folders)")
    assert none_cell == f"{100 * (0.25 + 9.5 / 128):.1f}"  # own-only's mean, less 2 units
    vfh = next(x for x in lines if x.startswith("| vfh | "))
    assert spl[vfh.split("|")[3].strip()] == "no run of this policy on this env at this drift"
    gains = _legend_of(lines, "## Paired comparisons")
    table = [x for x in lines if x.startswith("| fusion | ") or x.startswith("| collab | ")]
    cells = {tuple(c.strip() for c in x.strip("|").split("|")[:4]):
             [c.strip() for c in x.strip("|").split("|")] for x in table}
    absent = cells[("fusion", "bug-left", "walls", "exact")]
    assert absent[4] == "0" and len(set(absent[5:])) == 1
    assert gains[absent[5]] == ("no map has results of both the policy and its reference "
                                "(`vs`) in this env at this drift")
    same = cells[("fusion", "own-only", "walls", "none")]
    assert same[6] == same[8] and same[7] == f"{same[6]}; non-inferiority: normal approx."
    assert gains[same[6]] == ("every per-map difference is 0 (the policy and its reference, "
                              "`vs`, have the same SPL on each map): no two-sided test")
    assert cells[("fusion", "own-only", "walls", "exact")][6:8] == [f"{2 / 256:.2g}", "exact"]
    assert cells[("collab", "own-only", "walls", "none")][7] == "normal approx."
    assert any(x.startswith("`p_method` `exact`: from the exact null distribution")
               and "`normal approx.`:" in x for x in lines)
