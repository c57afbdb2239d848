"""report.md's sections on map difficulty (Spearman) and on why robots failed, on folders written
by the runner with a fake task function (fast, with failures of every cause)."""

from __future__ import annotations

import csv
import shutil
from collections import Counter

import numpy as np
import pandas as pd
import pytest

from fftnav.episode import EPISODE_COLUMNS, EpisodeRow
from fftnav.metrics import FAILURE_CAUSES
from fftnav.optimal.difficulty import MEASURES
from fftnav.report.difficulty import spearman_markdown
from fftnav.report.experiment import write_report
from fftnav.report.failures import REPLAY_COLUMN, failure_positions, failure_table
from fftnav.runner import TaskResult, parse_config, run_experiment
from fftnav.runner.maps import MAPS_COLUMNS, map_spl, spearman_table

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


def test_the_report_says_how_to_make_the_recording_of_a_failure(results, monkeypatch):
    monkeypatch.chdir(results.parent)
    report = write_report(CONFIG, results).read_text()
    order = {"env": CONFIG.envs.index, "policy": CONFIG.policy_names.index}  # the table's
    first = min(_failed_episodes(results),
                key=lambda k: (order["env"](k[0]), order["policy"](k[2]), int(k[1])))
    task = "-".join(first)
    assert (f"`fftnav replay results --task {task} --out {task}.html` reruns that episode"
            in report)
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


def test_a_folder_without_the_failure_column_says_so(results):
    episodes = pd.read_csv(results / "episodes.csv").drop(columns="failure")
    episodes.to_csv(results / "episodes.csv", index=False)
    report = write_report(CONFIG, results).read_text()
    assert "(`episodes.csv` has no `failure` column" in report
