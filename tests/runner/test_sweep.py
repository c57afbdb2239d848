"""[sweep] configs (one-factor-at-a-time cells) and the gain table of the sweep report."""

from __future__ import annotations

import copy
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from fftnav.runner import load_config, parse_config
from fftnav.runner.summary import SWEEP_COLUMNS, gain_table, holm

ROOT = Path(__file__).resolve().parents[2]

BASE = {
    "experiment": {"name": "s", "envs": ["walls", "forest"], "maps": 2, "map_seed": 1,
                   "robots": 4, "policies": ["own-only", "collab"], "out": "results/s"},
    "sweep": {"sensor.range_m": [1.5, 6.0], "episode.departure": ["waves"],
              "world.walls.wall_length_m": [[3.0, 4.5]], "comms.packet_loss": [0.3],
              "planner.heading_tol_deg": [20]},
}


def test_sweep_cells_are_the_base_and_one_value_at_a_time():
    config = parse_config(copy.deepcopy(BASE))
    names = [name for name, _ in config.cells]
    assert names == ["base", "range_m=1.5", "range_m=6", "departure=waves",
                     "wall_length_m=3-4.5", "packet_loss=0.3", "heading_tol_deg=20"]
    cells = dict(config.cells)
    assert cells["base"].swarm == config.swarm and cells["base"].out == "results/s/base"
    assert cells["range_m=1.5"].swarm.sensor.range_m == 1.5
    assert cells["range_m=1.5"].swarm.comms == config.swarm.comms
    assert cells["departure=waves"].swarm.episode.departure == "waves"
    assert cells["wall_length_m=3-4.5"].world_overrides("walls")["wall_length_m"] == [3.0, 4.5]
    assert cells["wall_length_m=3-4.5"].envs == ("walls",)  # the axis of one env's world
    assert cells["range_m=6"].envs == ("walls", "forest")
    assert cells["packet_loss=0.3"].out == "results/s/packet_loss=0.3"
    assert cells["heading_tol_deg=20"].swarm.planner.heading_tol_deg == 20.0
    assert cells["heading_tol_deg=20"].swarm.sensor == config.swarm.sensor
    assert parse_config({k: v for k, v in BASE.items() if k != "sweep"}).cells == ()


@pytest.mark.parametrize(("sweep", "message"), [
    ({"sensor.range": [1.0]}, r"sweep.sensor.range = 1.0: unknown key sensor.range"),
    ({"radio.loss": [0.1]}, r"unknown key sweep.radio.loss; expected 'section.key' of"),
    ({"comms.packet_loss": 0.3}, r"sweep.comms.packet_loss must be a non-empty list"),
    ({"comms.packet_loss": [1.5]}, r"sweep.comms.packet_loss = 1.5: comms.packet_loss must be"),
    ({"world.walls.colour": ["red"]}, r"sweep.world.walls.colour = 'red': unknown key "
                                       r"world.walls.colour"),
    ({"episode.departure": ["later"]}, r"episode.departure must be one of"),
    ({"planner.heading_tol_deg": [0]}, r"sweep.planner.heading_tol_deg = 0: "
                                       r"planner.heading_tol_deg must be a finite number"),
])
def test_bad_sweeps_are_refused_naming_the_key(sweep, message):
    with pytest.raises(ValueError, match=message):
        parse_config({**copy.deepcopy(BASE), "sweep": sweep})


def test_the_shipped_collab_configs_load():
    holdout = load_config(ROOT / "experiments" / "collab" / "walls_holdout.toml")
    assert holdout.envs == ("walls",) and holdout.maps == 20 and holdout.map_seed == 21
    fresh = load_config(ROOT / "experiments" / "collab" / "walls_fresh.toml")
    assert fresh.envs == ("walls",) and fresh.maps == 20 and fresh.map_seed == 41
    core = load_config(ROOT / "experiments" / "collab" / "core.toml")
    assert core.envs == ("walls", "traps") and core.maps == 20 and core.cells == ()
    assert {"own-only", "fusion", "collab"} <= set(core.policies)
    sweep = load_config(ROOT / "experiments" / "collab.toml")
    assert sweep.maps == 20 and set(sweep.envs) == {"forest", "rocky", "walls", "traps"}
    assert set(sweep.policies) == {"bug-left", "bug-right", "own-only", "fusion", "collab"}
    axes = {name.split("=")[0] for name, _ in sweep.cells} - {"base"}
    assert axes == {"range_m", "departure", "packet_loss", "wall_length_m"}


def test_gain_table_against_own_only_and_fusion_by_hand():
    rng = np.random.default_rng(0)
    rows = []
    spl = {"own-only": [0.5, 0.6, 0.7, 0.4, 0.5], "fusion": [0.5, 0.7, 0.6, 0.5, 0.5],
           "collab": [0.8, 0.9, 0.8, 0.7, 0.9]}
    for policy, values in spl.items():
        for m, v in enumerate(values):
            for r in range(2):  # two robots per map, both with the map's SPL
                rows.append(("walls", m, policy, r, v > 0.45, v, int(rng.integers(0, 100))))
    episodes = pd.DataFrame(rows, columns=["env", "map_seed", "policy", "robot", "arrived",
                                           "spl", "bytes_sent"])
    table = gain_table(episodes, "base")
    collab = table[(table.policy == "collab")].set_index("reference")
    diff = np.array(spl["collab"]) - np.array(spl["own-only"])
    assert collab.loc["own-only", "gain"] == pytest.approx(diff.mean())
    assert collab.loc["own-only", "p_value"] == pytest.approx(stats.wilcoxon(diff).pvalue)
    assert collab.loc["own-only", "gain_ci_low"] <= diff.mean() <= collab.loc["own-only",
                                                                             "gain_ci_high"]
    vs_fusion = np.array(spl["collab"]) - np.array(spl["fusion"])
    assert collab.loc["fusion", "gain"] == pytest.approx(vs_fusion.mean())
    own = table[table.policy == "own-only"].iloc[0]
    assert own.reference == "" and np.isnan(own.gain) and own.spl == pytest.approx(0.54)
    assert own.ar == pytest.approx(0.8) and own.maps == 5
    assert table[table.policy == "fusion"].reference.tolist() == ["own-only"]
    tested = table.reference != ""
    assert table.p_holm[tested].tolist() == pytest.approx(holm(table.p_value[tested]).tolist())
    assert table.p_holm[~tested].isna().all()


def test_figure_sweep_cli_writes_the_report_of_a_results_folder(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[experiment]\nname = "c"\nenvs = ["walls"]\nmaps = 2\nmap_seed = 1\n'
                   'robots = 4\npolicies = ["own-only", "collab"]\n')
    rows = [("walls", m, p, 0, True, 0.5 + 0.1 * m + (0.1 if p == "collab" else 0), 10)
            for m in range(2) for p in ("own-only", "collab")]
    pd.DataFrame(rows, columns=["env", "map_seed", "policy", "robot", "arrived", "spl",
                                "bytes_sent"]).to_csv(tmp_path / "episodes.csv", index=False)
    res = subprocess.run([sys.executable, "-m", "fftnav", "figure", "sweep", str(cfg), "--out",
                          str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    text = (tmp_path / "gains.md").read_text()
    assert "| base | walls | collab | 2 |" in text and "10.0 [10.0, 10.0]" in text
    assert (tmp_path / "figures" / "gain_cells.png").exists()
    assert (tmp_path / "sweep_summary.csv").exists()


@pytest.mark.parametrize(("gain", "low", "high", "p", "word"), [
    (0.05, 0.01, 0.09, 0.01, "pays"),
    (-0.05, -0.09, -0.01, 0.01, "costs"),
    (0.05, 0.01, 0.09, 0.06, "no clear difference"),  # interval above 0, p not below 0.05
    (0.02, -0.01, 0.05, 0.01, "no clear difference"),  # p below 0.05, interval across 0
    (np.nan, np.nan, np.nan, np.nan, "no clear difference"),
])
def test_verdict_needs_both_the_interval_and_the_paired_test(gain, low, high, p, word):
    from fftnav.report.sweep import verdict

    assert verdict(gain, low, high, p) == word


def test_verdict_lines_list_each_comparison_where_it_pays_and_costs():
    from fftnav.report.sweep import verdict_lines
    from fftnav.runner.summary import SWEEP_COLUMNS

    base = dict.fromkeys(SWEEP_COLUMNS, 0.0)
    rows = [
        {**base, "cell": "base", "env": "walls", "policy": "collab", "reference": "own-only",
         "gain": 0.08, "gain_ci_low": 0.03, "gain_ci_high": 0.12, "p_value": 0.002,
         "p_holm": 0.006},
        {**base, "cell": "range_m=6", "env": "walls", "policy": "collab",
         "reference": "own-only", "gain": -0.02, "gain_ci_low": -0.04, "gain_ci_high": -0.01,
         "p_value": 0.01, "p_holm": 0.02},
        {**base, "cell": "range_m=6", "env": "traps", "policy": "collab",
         "reference": "own-only", "gain": 0.03, "gain_ci_low": 0.01, "gain_ci_high": 0.05,
         "p_value": 0.03, "p_holm": 0.03 * 2},
        {**base, "cell": "base", "env": "walls", "policy": "collab", "reference": "fusion",
         "gain": 0.01, "gain_ci_low": -0.02, "gain_ci_high": 0.04, "p_value": 0.6,
         "p_holm": 1.0},
    ]
    text = "\n".join(verdict_lines(pd.DataFrame(rows, columns=list(SWEEP_COLUMNS))))
    assert "- `collab` against `own-only`, 3 (cell, env) pairs:" in text
    assert "  - pays in 1: base / walls (+8.0, p = 0.002, Holm p = 0.006)." in text
    assert "  - costs in 1: range_m=6 / walls (-2.0, p = 0.01, Holm p = 0.02)." in text
    assert ("  - no clear difference in 1.\n    - would pay by the raw p alone in 1: "
            "range_m=6 / traps (+3.0, p = 0.03, Holm p = 0.06).") in text
    assert "- `collab` against `fusion`, 1 (cell, env) pairs:" in text
    assert "  - pays in 0." in text and text.endswith("  - no clear difference in 1.")
    assert "would cost" not in text and "`fusion` against" not in text  # no such rows


def _episodes(spl: dict[str, list[float]]) -> pd.DataFrame:
    """One robot per map with the given SPL per policy, all arrived."""
    rows = [("walls", m, policy, 0, True, v, 10) for policy, values in spl.items()
            for m, v in enumerate(values)]
    return pd.DataFrame(rows, columns=["env", "map_seed", "policy", "robot", "arrived", "spl",
                                       "bytes_sent"])


def test_report_verdicts_use_the_holm_p_over_the_tests_of_the_report(tmp_path):
    from fftnav.report.sweep import write_sweep_report

    own = [0.5, 0.6, 0.7, 0.4, 0.5, 0.6]
    # collab better on all 6 maps, distinct differences: exact two-sided p = 2 / 2**6
    spl = {"own-only": own, "bug-left": own,  # bug-left equal to own-only: no p
           "collab": [v + 0.1 + 0.01 * m for m, v in enumerate(own)]}
    config = parse_config({"experiment": {"name": "h", "envs": ["walls"], "maps": 6,
                                          "map_seed": 0, "robots": 1,
                                          "policies": list(spl)}})
    _episodes(spl).to_csv(tmp_path / "episodes.csv", index=False)
    text = write_sweep_report(config, tmp_path).read_text()
    table = pd.read_csv(tmp_path / "sweep_summary.csv").set_index("policy")
    assert table.loc["collab", "p_value"] == pytest.approx(2 / 2**6, abs=1e-6)
    # the test without a p is not counted: a family of one, not adjusted, so collab pays
    assert np.isnan(table.loc["bug-left", "p_holm"])
    assert table.loc["collab", "p_holm"] == table.loc["collab", "p_value"]
    assert "all 1 paired comparisons of this report with a p" in text
    assert "1 more have no p" in text and "  - pays in 1: base / walls (+12.5," in text
    assert re.search(r"\| own-only \| 12\.5 \[[^]]*\] \| 0\.031 \| exact \| 0\.031 \| pays \|",
                     text)

    # fusion adds two tests: collab's raw p still passes, its Holm p >= 2 x 2 / 2**6 does not
    spl["fusion"] = [v + (0.02 if m % 2 else -0.01) for m, v in enumerate(own)]
    config = parse_config({"experiment": {"name": "h", "envs": ["walls"], "maps": 6,
                                          "map_seed": 0, "robots": 1,
                                          "policies": list(spl)}})
    _episodes(spl).to_csv(tmp_path / "episodes.csv", index=False)
    text = write_sweep_report(config, tmp_path).read_text()
    table = pd.read_csv(tmp_path / "sweep_summary.csv")
    collab = table[(table.policy == "collab") & (table.reference == "own-only")].iloc[0]
    assert collab.p_value == pytest.approx(2 / 2**6, abs=1e-6) and collab.p_holm >= 0.0625
    assert collab.gain_ci_low > 0  # the interval alone would still say "pays"
    assert "all 3 paired comparisons of this report with a p" in text
    assert "- `collab` against `own-only`, 1 (cell, env) pairs:\n  - pays in 0." in text
    assert "    - would pay by the raw p alone in 1: base / walls (+12.5, p = 0.031" in text
    # the smallest of the three p: 3 x 2 / 2**6 = 0.094
    assert re.search(r"\| own-only \| 12\.5 \[[^]]*\] \| 0\.031 \| exact \| 0\.094 \| no "
                     r"clear difference \|", text)


def test_an_axis_of_one_envs_world_draws_that_env_only():
    from fftnav.report.sweep import figure_envs

    table = pd.DataFrame({"cell": ["base", "base", "wall_length_m=3-4.5", "range_m=1.5",
                                   "range_m=1.5"],
                          "env": ["forest", "walls", "walls", "forest", "walls"]})
    assert figure_envs(table, "wall_length_m") == ["walls"]
    assert figure_envs(table, "range_m") == ["forest", "walls"]
    assert figure_envs(table[table.cell == "base"], "") == ["forest", "walls"]


def test_figure_sweep_works_from_the_committed_summary_plus_what_a_rerun_writes(tmp_path):
    """A committed sweep keeps each cell's summaries, not its episodes.csv: the report rebuilt
    without them (every cell, or only the cells a rerun has not written again) has the rows and
    verdicts of the report from the episodes, and names the cells it read from the summary."""
    from fftnav.report.sweep import write_sweep_report

    data = {"experiment": {"name": "w", "envs": ["walls"], "maps": 20, "map_seed": 0,
                           "robots": 1, "policies": ["own-only", "fusion", "collab"]},
            "sweep": {"comms.packet_loss": [0.3]}}
    config = parse_config(data)
    rng = np.random.default_rng(5)
    for k, (name, _) in enumerate(config.cells):
        own = rng.uniform(0.4, 0.8, 20)  # collab ahead on all 20 maps: exact p = 2 / 2**20
        spl = {"own-only": own, "fusion": own + rng.uniform(-0.01, 0.02, 20),
               "collab": own + 0.05 * (k + 1) + 0.0013 * np.arange(20)}
        (tmp_path / name).mkdir()
        _episodes(spl).to_csv(tmp_path / name / "episodes.csv", index=False)
    from_episodes = write_sweep_report(config, tmp_path).read_text()
    summary = pd.read_csv(tmp_path / "sweep_summary.csv")
    assert summary.p_value.min() == pytest.approx(2 / 2**20, rel=1e-5)  # not %.6f
    episodes = {name: (tmp_path / name / "episodes.csv").read_bytes() for name, _ in config.cells}
    for gone in (["packet_loss=0.3"], ["base", "packet_loss=0.3"]):
        for name in gone:
            (tmp_path / name / "episodes.csv").unlink()
        text = write_sweep_report(config, tmp_path).read_text()
        assert f"sweep_summary.csv` (their episodes.csv is not here; rerun them with `fftnav " \
               f"run` to recompute them): {', '.join(gone)}." in text
        assert text.replace(text.split("\n\n")[2] + "\n\n", "", 1) == from_episodes
        again = pd.read_csv(tmp_path / "sweep_summary.csv")
        pd.testing.assert_frame_equal(again, summary, rtol=1e-5)
        for name, data_ in episodes.items():  # what a rerun writes back
            (tmp_path / name / "episodes.csv").write_bytes(data_)


def _legend(text: str) -> dict[str, str]:
    """The marks of a report's legend line (`-¹` reason; `-²` reason.) -> their reasons."""
    line = next(x for x in text.splitlines() if x.startswith("`-¹` "))
    return dict(re.findall(r"`(-[¹²³⁴⁵⁶⁷⁸⁹⁰]+)` (.*?)(?:; (?=`-)|\.$)", line))


def _row(text: str, **cells: str) -> dict[str, str]:
    """The one row of the report's table whose columns hold ``cells``, by the header."""
    lines = [x for x in text.splitlines() if x.startswith("| ")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = [dict(zip(header, (c.strip() for c in x.strip("|").split("|")), strict=True))
            for x in lines[1:]]
    found = [r for r in rows if all(r[k.replace("_", " ")] == v for k, v in cells.items())]
    assert len(found) == 1, (cells, found)
    return found[0]


def test_every_missing_number_of_the_sweep_report_says_why_and_each_p_how(tmp_path):
    """A hand-made sweep whose missing numbers have known reasons: own-only (the reference),
    fusion equal to own-only on walls (every difference 0), forest without own-only (no map
    with both), traps with one map (no interval over maps), and a cell read from a summary
    that does not record how its p was computed; collab's p on walls' 24 tied differences is
    the normal approximation's, on traps' one difference exact (2 x 1/2 = 1)."""
    from fftnav.report.sweep import write_sweep_report

    config = parse_config({"experiment": {"name": "d", "envs": ["walls", "traps", "forest"],
                                          "maps": 24, "map_seed": 0, "robots": 1,
                                          "policies": ["own-only", "fusion", "collab"]},
                           "sweep": {"comms.packet_loss": [0.3]}})
    own = 0.5 + 0.01 * np.arange(24)
    diff = 0.01 * (1 + np.arange(24) // 2)  # 24 positive differences, tied in pairs
    rows = [("walls", m, p, 0, True, v, 10) for p, values in
            (("own-only", own), ("fusion", own), ("collab", own + diff))
            for m, v in enumerate(values)]
    rows += [("traps", 0, "own-only", 0, True, 0.6, 0), ("traps", 0, "collab", 0, True, 0.7, 5),
             ("traps", 0, "fusion", 0, True, 0.6, 9)]
    rows += [("forest", m, p, 0, True, 0.9, 1) for m in range(3) for p in ("fusion", "collab")]
    (tmp_path / "base").mkdir()
    pd.DataFrame(rows, columns=["env", "map_seed", "policy", "robot", "arrived", "spl",
                                "bytes_sent"]).to_csv(tmp_path / "base" / "episodes.csv",
                                                      index=False)
    old = pd.DataFrame([{**dict.fromkeys(SWEEP_COLUMNS, 0.5), "cell": "packet_loss=0.3",
                         "env": "walls", "policy": "collab", "maps": 24,
                         "reference": "own-only", "gain": 0.1, "gain_ci_low": 0.05,
                         "gain_ci_high": 0.15, "p_value": 0.002, "p_holm": 0.002}])
    old.to_csv(tmp_path / "sweep_summary.csv", index=False)  # SWEEP_COLUMNS: no p_method
    text = write_sweep_report(config, tmp_path).read_text()
    reasons = _legend(text)

    def why(cell: str) -> str:
        return reasons[cell.split("[")[-1].rstrip("]")]

    collab = _row(text, cell="base", env="walls", policy="collab", vs="own-only")
    assert collab["vs"] == "own-only" and collab["p_method"] == "normal approx."
    # all 24 positive: rank sum 300 against a mean of 24 x 25 / 4 = 150, variance
    # 24 x 25 x 49 / 24 less 12 ties of two x (2^3 - 2) / 48 = 1223.5 (no continuity correction)
    z = (300 - 150) / np.sqrt(1223.5)
    assert collab["p (Wilcoxon)"] == f"{2 * stats.norm.sf(z):.2g}" == "1.8e-05"
    own_row = _row(text, cell="base", env="walls", policy="own-only")
    assert {own_row[c] for c in ("vs", "gain (SPL points)", "p (Wilcoxon)", "p_method",
                                 "p (Holm)", "verdict")} == {own_row["vs"]}
    assert why(own_row["vs"]) == ("`own-only` is the reference of the gains: it is not "
                                  "compared with itself")
    fusion = _row(text, cell="base", env="walls", policy="fusion")
    assert fusion["gain (SPL points)"] == "0.0 [0.0, 0.0]"
    assert fusion["p (Wilcoxon)"] == fusion["p_method"] == fusion["p (Holm)"]
    assert why(fusion["p (Wilcoxon)"]) == (
        "every per-map difference is 0 (the policy and its reference, `vs`, have the same SPL "
        "on each map): no test")
    traps = _row(text, cell="base", env="traps", policy="collab", vs="own-only")
    assert traps["AR %"].startswith("100.0 [-") and traps["p (Wilcoxon)"] == "1"
    assert traps["p_method"] == "exact"
    assert why(traps["SPL %"]) == "1 map: no interval over maps (it needs two or more)"
    forest = _row(text, cell="base", env="forest", policy="fusion")
    assert forest["vs"] == "own-only" and forest["gain (SPL points)"] == forest["p (Wilcoxon)"]
    assert why(forest["p (Wilcoxon)"]) == ("no map has results of both the policy and its "
                                           "reference (`vs`) in this env")
    kept = _row(text, cell="packet_loss=0.3", env="walls", policy="collab")
    assert kept["p (Wilcoxon)"] == "0.002"
    assert why(kept["p_method"]).startswith("`sweep_summary.csv` does not record how this p was "
                                            "computed (no `p_method`)")
    # the family: collab's 2 rows at walls, 2 at traps and 1 in the kept cell; without a p,
    # fusion at walls and traps and collab against fusion in the forest (equal), fusion and
    # collab against own-only in the forest (no map with both)
    assert ("all 5 paired comparisons of this report with a p (every policy against `own-only` "
            "and `collab` against `fusion`, in every cell and env; 3 more have no p, every "
            "per-map difference being 0; 2 more have no map with both policies)") in text
    assert "`p_method` `exact`: from the exact null distribution" in text
    assert "`normal approx.`: the normal approximation" in text
    assert not re.search(r"\| +\|", text)  # no empty cell anywhere
    summary = pd.read_csv(tmp_path / "sweep_summary.csv", keep_default_na=False)
    methods = summary.set_index(["cell", "env", "policy", "reference"])["p_method"]
    assert methods[("base", "walls", "collab", "own-only")] == "normal approx."
    assert methods[("base", "traps", "collab", "own-only")] == "exact"
    assert methods[("base", "walls", "fusion", "own-only")] == ""  # no p
    assert methods[("packet_loss=0.3", "walls", "collab", "own-only")] == ""  # not recorded
