"""report.md's sections on map difficulty (Spearman) and on why robots failed, the paper's
columns only beside the paper's protocol, and the reason of every missing number, on folders
written by the runner with a fake task function (fast, with failures of every cause)."""

from __future__ import annotations

import csv
import dataclasses
import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fftnav.episode import EPISODE_COLUMNS, EpisodeRow
from fftnav.metrics import FAILURE_CAUSES
from fftnav.optimal.difficulty import MEASURES
from fftnav.report.difficulty import spearman_markdown
from fftnav.report.experiment import (
    PAPER_NAMES,
    PAPER_TABLE1,
    is_paper_protocol,
    p_method_lines,
    paired_table,
    results_table,
    write_report,
)
from fftnav.report.failures import REPLAY_COLUMN, failure_positions, failure_table
from fftnav.report.markdown import Dashes
from fftnav.runner import TaskResult, load_config, parse_config, run_experiment, summarize
from fftnav.runner.maps import MAPS_COLUMNS, map_spl, spearman_table
from fftnav.runner.summary import paired_tests

ROOT = Path(__file__).resolve().parents[2]

CONFIG = parse_config({
    "experiment": {"name": "sections", "envs": ["forest", "rocky"], "maps": 6, "map_seed": 3,
                   "robots": 4, "policies": ["bug-left", "fusion"], "trajectory_maps": 2},
    "world": {"size_m": [8.0, 8.0], "goal_y_m": 7.0},
}, source="# sections\n")
CAUSES = list(FAILURE_CAUSES)


def fake_task(config, task):
    """Rows whose ``spl`` falls with the map seed (whether the robot arrived or not, so that the
    per-map SPL ranks the maps exactly); a failing robot gets a random cause of the registry;
    trajectories end at a position drawn from the task's seed."""
    rng = np.random.default_rng([task.episode_seed, len(task.policy)])
    rows = []
    for r in range(config.robots):
        arrived = bool(rng.random() < 0.6)
        cause = "" if arrived else CAUSES[int(rng.integers(len(CAUSES)))]
        rows.append(EpisodeRow(**{**{c: 1.0 for c in EPISODE_COLUMNS}, "robot": r,
                                  "policy": task.policy, "arrived": arrived, "collided": False,
                                  "spl": 1 - task.map_seed / 20,
                                  "failure": cause}))
    trajectories = ([np.c_[rng.uniform(0, 8, (5, 2)), np.zeros(5)] for _ in rows]
                    if task.keep_trajectories else None)
    return TaskResult(rows, trajectories)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("sections")
    run_experiment(CONFIG, out, task_fn=fake_task, workers=1, progress=False)
    return out


@pytest.fixture
def results(folder, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(folder, out)
    return out


def _csv_counts(out):
    """(env, policy, cause) -> robots, read with the csv module (an independent reader)."""
    with open(out / "episodes.csv", newline="") as fh:
        return Counter((r["env"], r["policy"], r["failure"]) for r in csv.DictReader(fh)
                       if r["arrived"] == "false")


def test_failure_table_counts_are_those_of_episodes_csv(results):
    episodes = pd.read_csv(results / "episodes.csv")
    table = failure_table(episodes, envs=CONFIG.envs, policies=CONFIG.policy_names)
    assert list(table.columns) == ["env", "policy", "robots", "failed", *CAUSES, REPLAY_COLUMN]
    assert list(zip(table.env, table.policy, strict=True)) == [
        (e, p) for e in CONFIG.envs for p in CONFIG.policy_names]
    counts = _csv_counts(results)
    assert sum(counts.values()) > 10 and len({c for _, _, c in counts}) == len(CAUSES)
    for r in table.to_dict("records"):
        assert r["robots"] == CONFIG.maps * CONFIG.robots
        assert r["failed"] == sum(n for (e, p, _), n in counts.items()
                                  if (e, p) == (r["env"], r["policy"]))
        for cause in CAUSES:
            assert r[cause] == counts[r["env"], r["policy"], cause]
        tasks = sorted({(int(m), f"`{e}-{m}-{p}`") for e, m, p in _failed_episodes(results)
                        if (e, p) == (r["env"], r["policy"])})
        assert r[REPLAY_COLUMN] == (", ".join(t for _, t in tasks) or "-")
    report = write_report(CONFIG, results).read_text()
    section = report[report.index("## Why robots failed"):report.index("## Figures")]
    for r in table.to_dict("records"):
        cells = [r["env"], r["policy"], r["robots"], r["failed"], *(r[c] for c in CAUSES),
                 r[REPLAY_COLUMN]]
        assert "| " + " | ".join(map(str, cells)) + " |" in section


def _failed_episodes(out):
    """(env, map_seed, policy) of every episode with a robot that did not arrive (csv module)."""
    with open(out / "episodes.csv", newline="") as fh:
        return {(r["env"], r["map_seed"], r["policy"]) for r in csv.DictReader(fh)
                if r["arrived"] == "false"}


def test_the_report_says_how_to_make_the_replay_page_of_a_failure(results, monkeypatch):
    monkeypatch.chdir(results.parent)
    report = write_report(CONFIG, results).read_text()
    order = {"env": CONFIG.envs.index, "policy": CONFIG.policy_names.index}  # the list's
    first = min(_failed_episodes(results),
                key=lambda k: (order["env"](k[0]), int(k[1]), order["policy"](k[2])))
    task = "-".join(first)
    assert (f"`fftnav replay results --task {task} --out results/replays/{task}.html` reruns "
            "that episode" in report)
    assert report.count("`fftnav replay results --task") == 1  # said once
    assert not (results / "records").exists() or not any((results / "records").iterdir())


def test_failure_positions_are_the_last_points_of_the_failed_robots(results):
    positions = failure_positions(results)
    assert list(positions.columns) == ["env", "map_seed", "policy", "robot", "cause", "x", "y"]
    episodes = pd.read_csv(results / "episodes.csv")
    failed = episodes[~episodes.arrived & (episodes.map_seed < 3 + CONFIG.trajectory_maps)]
    assert len(positions) == len(failed) > 0
    assert set(positions.map_seed) <= {3, 4}  # only the maps that keep trajectories
    for r in positions.itertuples(index=False):
        with np.load(results / "trajectories" / f"{r.env}-{r.map_seed}-{r.policy}.npz") as z:
            assert (r.x, r.y) == tuple(z[f"arr_{r.robot}"][-1, :2])
        row = failed[(failed.env == r.env) & (failed.map_seed == r.map_seed)
                     & (failed.policy == r.policy) & (failed.robot == r.robot)]
        assert row.failure.tolist() == [r.cause]
    report = write_report(CONFIG, results).read_text()
    assert f"Where they ended: {len(positions)} of the {len(episodes) - episodes.arrived.sum()}" \
        in report
    assert "![failure_positions](figures/failure_positions.png)" in report
    assert (results / "figures" / "failure_positions.png").read_bytes()[:4] == b"\x89PNG"


def test_report_without_maps_csv_skips_the_difficulty_figure(results):
    assert not (results / "maps.csv").exists()  # a fake task function writes none
    report = write_report(CONFIG, results).read_text()
    # not the paper's protocol (8 m worlds, 6 maps, 4 robots): no paper column
    assert "## Results\n" in report and "paper AR %" not in report
    assert "The paper's Table I is not shown: this experiment is not the paper's protocol" \
        in report
    assert "(no `maps.csv` in this folder: rerun `fftnav run` on it to write it)" in report
    assert not (results / "figures" / "spl_vs_difficulty.png").exists()
    assert "## Why robots failed" in report and "| forest | fusion |" in report


def test_report_with_maps_csv_has_the_spearman_table_and_figure(results):
    rng = np.random.default_rng(0)
    keys = [(e, s, r) for e in sorted(CONFIG.envs) for s in range(3, 9) for r in range(4)]
    maps = pd.DataFrame(keys, columns=["env", "map_seed", "robot"])
    for name in MEASURES:
        maps[name] = rng.random(len(maps))
    maps["tortuosity"] = 1 + maps.map_seed / 10 + maps.robot / 100  # SPL falls as it grows
    maps[list(MAPS_COLUMNS)].to_csv(results / "maps.csv", index=False, float_format="%.6f")
    report = write_report(CONFIG, results).read_text()
    assert (results / "figures" / "spl_vs_difficulty.png").read_bytes()[:4] == b"\x89PNG"
    assert "![spl_vs_difficulty](figures/spl_vs_difficulty.png)" in report
    expected = spearman_markdown(spearman_table(
        map_spl(pd.read_csv(results / "episodes.csv"), pd.read_csv(results / "maps.csv")),
        envs=CONFIG.envs, policies=CONFIG.policy_names))
    assert len(expected) == 3 * 2
    for row in expected.astype(str).to_numpy():
        assert "| " + " | ".join(row) + " |" in report
    # the per-map SPL is 1 - seed/20, the mean tortuosity grows with the seed: rho = -1
    assert expected["tortuosity"].str.startswith("**-1.00 (").all()
    assert expected["predicts SPL (p < 0.05)"].str.contains("tortuosity (-)", regex=False).all()
    # 6 maps per env: exact, 1 ordering of 6! as extreme in each direction; 12 pooled: t
    per_env = expected[expected.scope != "all"]
    assert (per_env["tortuosity"] == f"**-1.00 ({2 / 720:.2g})**").all()
    assert ("Spearman p-values above: exact (all n! orderings of the maps) in the 4 row(s) of "
            "at most 9 maps (scope forest, rocky); from the t approximation in the 2 row(s) of "
            "more than 9 maps (scope all).") in report


def test_a_folder_without_the_failure_column_says_so(results):
    episodes = pd.read_csv(results / "episodes.csv").drop(columns="failure")
    episodes.to_csv(results / "episodes.csv", index=False)
    report = write_report(CONFIG, results).read_text()
    assert "(`episodes.csv` has no `failure` column" in report


def test_the_paper_protocol_is_table1s_and_nothing_else(tmp_path):
    table1 = load_config(ROOT / "experiments" / "table1.toml")
    assert is_paper_protocol(table1)
    base = {"name": "p", "envs": ["forest", "rocky"], "maps": 20, "map_seed": 1000,
            "robots": 15, "policies": ["fusion", "own-only"]}
    assert is_paper_protocol(parse_config({"experiment": {**base, "envs": ["rocky"]},
                                           "record": {"episodes": "all"}}))
    others = [
        {"experiment": {**base, "envs": ["forest", "walls"]}},
        {"experiment": {**base, "maps": 19}},
        {"experiment": {**base, "map_seed": 1001}},
        {"experiment": {**base, "robots": 14}},
        {"experiment": base, "comms": {"packet_loss": 0.3}},
        {"experiment": base, "sensor": {"range_m": 6.0}},
        {"experiment": base, "episode": {"departure": "waves"}},
        {"experiment": base, "planner": {"drive": "straight"}},
        {"experiment": base, "localization": {"mode": "odometry"}},
        {"experiment": base, "world": {"size_m": [30.0, 30.0]}},
        {"experiment": base, "world": {"rocky": {"size_m": [30.0, 30.0]}}},
    ]
    for data in others:
        assert not is_paper_protocol(parse_config(data)), data
    files = dataclasses.replace(parse_config({"experiment": base}),
                                world_files={"forest": str(tmp_path / "w.json")})
    assert not is_paper_protocol(files)
    assert not is_paper_protocol(CONFIG)


def test_the_papers_columns_stand_beside_the_papers_protocol(tmp_path):
    paper = parse_config({"experiment": {
        "name": "paper", "envs": ["forest", "rocky"], "maps": 20, "map_seed": 1000,
        "robots": 15, "policies": ["bug-left", "fusion", "own-only"], "trajectory_maps": 0}},
        source="# paper\n")
    assert is_paper_protocol(paper)
    run_experiment(paper, tmp_path, task_fn=fake_task, workers=1, progress=False)
    report = write_report(paper, tmp_path).read_text()
    assert "## Results beside the paper's Table I\n" in report
    lines = [line for line in report.splitlines() if line.startswith("| ")]
    assert lines[0] == ("| env | policy | paper name | AR % | APL m | SPL % | SPL geodesic % | "
                        "paper AR % | paper APL m | paper SPL % |")
    for env in ("forest", "rocky"):
        for policy in ("bug-left", "fusion"):  # the paper's figures, as printed in its table
            ar, apl, spl = PAPER_TABLE1[env, policy]
            row = next(line for line in lines if line.startswith(f"| {env} | {policy} |"))
            assert row.endswith(f"| {ar:.1f} | {apl:.3f} | {spl:.1f} |")
            assert f"| {PAPER_NAMES[policy]} |" in row
        own = next(line for line in lines if line.startswith(f"| {env} | own-only |"))
        assert own.startswith(f"| {env} | own-only | -¹ |") and own.endswith("| -² | -² | -² |")
    assert ("`-¹` the policy is not one of the paper's methods; `-²` the paper's Table I has no "
            "row of this env and policy.") in report


def _hand_episodes(rows):
    """Episodes of the given (env, map_seed, policy, arrived, spl), one robot per row."""
    table = pd.DataFrame(rows, columns=["env", "map_seed", "policy", "arrived", "spl"])
    return table.assign(robot=table.groupby(["env", "map_seed", "policy"]).cumcount(),
                        collided=False, path_length_m=np.where(table.arrived, 20.0, 5.0),
                        optimal_length_m=18.0, geodesic_length_m=17.5, time_s=30.0,
                        bytes_sent=0, messages_sent=0, decisions_left=0, decisions_right=0,
                        decisions_with_neighbours=0, decisions_flipped_by_neighbours=0,
                        robot_contacts=0, failure=np.where(table.arrived, "", "stuck"))


def test_every_missing_number_of_the_results_table_says_why():
    episodes = _hand_episodes([
        # "one": a single map, so no interval over maps
        ("forest", 1, "one", True, 0.9), ("forest", 1, "one", False, 0.0),
        # "none": no robot arrives on either map, so no APL at all
        *[("forest", m, "none", False, 0.0) for m in (1, 2) for _ in range(2)],
        # "half": no robot arrives on map 2 of 2: a resample of map 2 alone has no APL
        ("forest", 1, "half", True, 0.9), ("forest", 1, "half", True, 0.8),
        ("forest", 2, "half", False, 0.0), ("forest", 2, "half", False, 0.0),
    ])
    summary = summarize(episodes, policies=["one", "none", "half"], n_resamples=200)
    dashes = Dashes()
    table = results_table(summary, episodes, paper=False, dashes=dashes).set_index("policy")
    assert "paper AR %" not in table
    assert table.loc["one", "AR %"] == "50.0 [-¹]"
    assert table.loc["one", "APL m"] == "20.000 [-¹]"
    assert table.loc["none", "APL m"] == "-²"
    assert table.loc["none", "AR %"] == "0.0 [0.0, 0.0]"
    assert table.loc["half", "APL m"] == "20.000 [-³]"
    assert table.loc["half", "AR %"].startswith("50.0 [") and "-" not in table.loc["half", "AR %"]
    assert dashes.legend() == [
        "`-¹` 1 map: no interval over maps (it needs two or more); `-²` no robot arrived (APL "
        "is the mean path length of the robots that arrived); `-³` 1 of the 2 maps had no robot "
        "arrive: a bootstrap resample of those maps alone has no APL, so the interval is "
        "undefined."]


def test_a_paired_test_without_p_says_why():
    episodes = _hand_episodes([
        *[("forest", m, p, True, 0.9) for m in (1, 2, 3) for p in ("fusion", "same")],
        ("forest", 1, "apart", True, 0.5), ("rocky", 1, "fusion", True, 0.7),
        ("rocky", 2, "apart", True, 0.6),
    ])
    paired = paired_tests(episodes, policies=["fusion", "same", "apart"])
    dashes = Dashes()
    shown = paired_table(paired, dashes=dashes).set_index(["env", "policy"])
    assert shown.loc[("forest", "same"), "p_value"] == "-¹"  # identical SPL on 3 maps
    assert shown.loc[("forest", "same"), "statistic"] == "-¹"
    assert shown.loc[("forest", "same"), "median_diff"] == 0
    assert shown.loc[("forest", "apart"), "p_value"] == "1"  # one map: p = 2 x 1/2
    assert shown.loc[("rocky", "same"), "p_value"] == "-²"  # no map with both
    assert shown.loc[("rocky", "apart"), "p_value"] == "-³"
    assert shown.loc[("rocky", "apart"), "spl_policy"] == "-³"
    assert dashes.legend() == [
        "`-¹` every paired difference is 0 (`fusion` and `same` have the same SPL on each of "
        "the 3 maps): no test; `-²` no map has results of both `fusion` and `same` on rocky; "
        "`-³` no map has results of both `fusion` and `apart` on rocky."]


def test_the_report_says_how_each_p_was_computed(results):
    paired = pd.read_csv(results / "paired_tests.csv")
    assert paired["p_value"].isna().all()  # every policy has the same per-map SPL here
    paired["p_method"] = paired["p_method"].astype(object)  # empty: read as NaN
    paired.loc[0, ["statistic", "p_value", "p_method"]] = [0.0, 2 / 64, "exact"]
    paired.loc[1, ["statistic", "p_value", "p_method"]] = [12.0, 0.2, "normal approx."]
    paired.to_csv(results / "paired_tests.csv", index=False)
    report = write_report(CONFIG, results).read_text()
    assert "| forest | fusion | bug-left | 6 | 0.725 | 0.725 | 0 | 0.0 | 0.031 | exact |" in report
    assert "| 12.0 | 0.2 | normal approx. |" in report
    assert "`p_method` `exact`: from the exact null distribution, the 2^n equally likely signs" \
        in report
    assert ("`normal approx.`: the normal approximation (scipy's default: no continuity "
            "correction, the variance corrected for ties)") in report
    assert "this `paired_tests.csv` has no `p_method` column" in p_method_lines(
        paired.drop(columns="p_method"))[0]  # a folder written before p_method
    assert p_method_lines(paired.iloc[2:]) == []  # no p-value, nothing to say
