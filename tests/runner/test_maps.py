"""maps.csv (BARN's difficulty measures per map and robot) and the Spearman table of per-map SPL."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
from scipy import stats

import fftnav.runner.maps as maps_module
import fftnav.runner.run as run_module
from fftnav.optimal.difficulty import MEASURES, map_difficulty
from fftnav.runner import parse_config, run_experiment
from fftnav.runner.maps import (
    MAPS_COLUMNS,
    map_spl,
    maps_current,
    maps_table,
    spearman_table,
    write_maps_csv,
)
from fftnav.runner.tasks import task_world
from tests.runner.test_maps_exact import brute_force_spearman_p

#: Small 8 m x 8 m forests (the smoke experiment's), 2 envs x 2 maps x 3 robots.
SMALL = {
    "experiment": {"name": "maps", "envs": ["rocky", "forest"], "maps": 2, "map_seed": 7,
                   "robots": 3, "policies": ["bug-left"]},
    "world": {"size_m": [8.0, 8.0], "goal_y_m": 7.0},
    "episode": {"time_limit_s": 4.0},
}


def small(**robot):
    return parse_config({**SMALL, **({"robot": robot} if robot else {})}, source="# maps\n")


def test_maps_table_is_map_difficulty_of_every_world_with_r0_from_the_config():
    for r0 in (0.15, 0.2):
        config = small(r0_m=r0, r_m=2 * r0)
        table = maps_table(config)
        assert tuple(table.columns) == MAPS_COLUMNS
        assert list(table.itertuples(index=False, name=None))[0][:3] == ("forest", 7, 0)
        keys = [("forest", 7), ("forest", 8), ("rocky", 7), ("rocky", 8)]  # sorted like the CSVs
        assert [k for k, _ in table.groupby(["env", "map_seed"], sort=False)] == keys
        for env, seed in keys:
            rows = table[(table.env == env) & (table.map_seed == seed)]
            assert rows.robot.tolist() == [0, 1, 2]
            expected = map_difficulty(task_world(config, env, seed), r0_m=r0)
            for name in MEASURES:
                np.testing.assert_allclose(rows[name], expected[name], rtol=0, atol=0)
    # a larger r0 narrows the free space: the clearance along the paths shrinks
    assert (maps_table(small(r0_m=0.2, r_m=0.4)).distance_to_closest_obstacle_m
            < maps_table(small()).distance_to_closest_obstacle_m).all()


def test_maps_csv_is_deterministic_with_six_decimals_and_the_same_on_two_workers(tmp_path):
    config = small()
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    one = write_maps_csv(tmp_path / "a", config)
    two = write_maps_csv(tmp_path / "b", config, workers=2)
    assert one.read_bytes() == two.read_bytes()
    lines = one.read_text().splitlines()
    assert lines[0] == ",".join(MAPS_COLUMNS) and len(lines) == 1 + 2 * 2 * 3
    assert all(len(cell.split(".")[1]) == 6 for cell in lines[1].split(",")[3:])
    back = pd.read_csv(one)
    np.testing.assert_allclose(back[list(MEASURES)], maps_table(config)[list(MEASURES)],
                               atol=5e-7, rtol=0)
    assert not list(tmp_path.glob("*/.*tmp"))  # written through a temporary file


def test_a_map_without_reference_paths_gets_nan_and_a_bug_raises(tmp_path, monkeypatch):
    real = maps_module.map_difficulty

    def unreachable(world, **kwargs):
        if world.env == "rocky" and world.seed == 8:
            raise ValueError("goal unreachable")
        return real(world, **kwargs)

    monkeypatch.setattr(maps_module, "map_difficulty", unreachable)
    table = maps_table(small())
    bad = (table.env == "rocky") & (table.map_seed == 8)
    assert bad.sum() == 3 and table.loc[bad, list(MEASURES)].isna().all().all()
    assert table.loc[~bad, list(MEASURES)].notna().all().all()
    monkeypatch.setattr(maps_module, "map_difficulty",
                        lambda world, **kwargs: 1 / 0)
    with pytest.raises(RuntimeError, match="difficulty of map forest-7 failed: "
                                           "ZeroDivisionError"):
        maps_table(small())


def test_maps_current_checks_the_maps_the_columns_and_the_robots(tmp_path):
    config = small()
    assert not maps_current(tmp_path, config)  # missing
    path = write_maps_csv(tmp_path, config)
    assert maps_current(tmp_path, config)
    table = pd.read_csv(path)
    for stale in (table[table.map_seed == 7],                       # a map missing
                  table[table.robot < 2],                           # a robot missing
                  table.drop(columns="tortuosity"),                 # a column missing
                  table.assign(env=table.env.replace("rocky", "walls"))):  # another env
        stale.to_csv(path, index=False)
        assert not maps_current(tmp_path, config)
    path.write_bytes(b"\xff\xfe")
    assert not maps_current(tmp_path, config)
    write_maps_csv(tmp_path, config)
    assert not maps_current(tmp_path, dataclasses.replace(config, maps=3))


def test_run_experiment_writes_maps_csv_and_keeps_it_on_resume(tmp_path, monkeypatch):
    config = parse_config({**SMALL, "experiment": {**SMALL["experiment"], "envs": ["forest"],
                                                   "maps": 1, "robots": 2}}, source="# m\n")
    run_experiment(config, tmp_path, workers=1, progress=False)
    path = tmp_path / "maps.csv"
    assert path.read_bytes() == maps_table(config).to_csv(index=False,
                                                          float_format="%.6f").encode()
    before = {p: (tmp_path / p).read_bytes() for p in ("episodes.csv", "maps.csv")}

    def never(*args, **kwargs):
        raise AssertionError("maps.csv recomputed")

    monkeypatch.setattr(run_module, "write_maps_csv", never)
    outcome = run_experiment(config, tmp_path, workers=1, progress=False)  # nothing to do
    assert (outcome.completed, outcome.skipped) == (0, 1)
    assert {p: (tmp_path / p).read_bytes() for p in before} == before
    monkeypatch.undo()
    path.write_text("env,map_seed\nforest,1\n")  # stale: rewritten by a resume
    run_experiment(config, tmp_path, workers=1, progress=False)
    assert path.read_bytes() == before["maps.csv"]


def _per_map(rng):
    """A constructed per-map table: 2 envs x 12 maps x 2 policies."""
    rows = []
    for env in ("a", "b"):
        for seed in range(12):
            measures = {m: rng.normal() for m in MEASURES}
            for policy in ("p", "q"):
                rows.append({"env": env, "map_seed": seed, "policy": policy,
                             "spl": rng.random(), **measures})
    return pd.DataFrame(rows)


def _ranks_pearson(x, y):
    """Spearman's rho as the Pearson correlation of ranks (no ties in continuous data)."""
    rx, ry = np.argsort(np.argsort(x)), np.argsort(np.argsort(y))
    return float(np.corrcoef(rx, ry)[0, 1])


def test_spearman_table_per_scope_policy_and_measure_exact_on_few_maps():
    per_map = _per_map(np.random.default_rng(3))
    per_map.loc[(per_map.env == "a") & (per_map.map_seed < 4), "tortuosity"] = np.nan
    per_map.loc[per_map.policy == "q", "spl"] += 2 * per_map.loc[per_map.policy == "q",
                                                                 "dispersion"]
    table = spearman_table(per_map, envs=["b", "a"], policies=["q", "p"])
    assert list(table.columns) == ["scope", "policy", "measure", "maps", "rho", "p_value",
                                   "p_method"]
    assert list(dict.fromkeys(table.scope)) == ["all", "b", "a"]
    assert len(table) == 3 * 2 * len(MEASURES)
    for r in table.itertuples(index=False):
        sub = per_map[per_map.policy == r.policy]
        sub = sub if r.scope == "all" else sub[sub.env == r.scope]
        sub = sub[["spl", r.measure]].dropna()
        assert r.maps == len(sub)
        expected = stats.spearmanr(sub.spl, sub[r.measure])
        assert r.rho == pytest.approx(expected.statistic, abs=1e-12)
        if r.maps <= 9:  # 8 maps of env a with tortuosity: every ordering enumerated
            assert r.p_method == "exact"
            assert r.p_value == pytest.approx(
                brute_force_spearman_p(sub.spl.to_numpy(), sub[r.measure].to_numpy()),
                rel=1e-9)
        else:
            assert r.p_method == "t approx."
            assert r.p_value == pytest.approx(expected.pvalue, rel=1e-9)
        assert r.rho == pytest.approx(_ranks_pearson(sub.spl.to_numpy(),
                                                     sub[r.measure].to_numpy()), abs=1e-12)
    q = table[(table.policy == "q") & (table.measure == "dispersion")]
    assert (q.rho > 0.5).all() and (q.p_value < 0.05).all()  # the built-in dependence is found
    assert table[(table.scope == "a") & (table.measure == "tortuosity")].maps.tolist() == [8, 8]


def test_spearman_table_gives_nan_without_a_ranking():
    per_map = _per_map(np.random.default_rng(4))
    per_map.loc[per_map.policy == "p", "spl"] = 1.0  # every map solved perfectly
    per_map = per_map[(per_map.env == "a") | (per_map.map_seed < 2)]  # env b: 2 maps
    table = spearman_table(per_map)
    assert table[table.policy == "p"][["rho", "p_value"]].isna().all().all()
    assert table[(table.scope == "b")][["rho", "p_value"]].isna().all().all()
    assert table[(table.scope == "a") & (table.policy == "q")].rho.notna().all()


def test_map_spl_averages_the_robots_of_each_map():
    episodes = pd.DataFrame({"env": "e", "map_seed": [1, 1, 1, 1, 2, 2], "robot": [0, 1] * 3,
                             "policy": ["p", "p", "q", "q", "p", "p"],
                             "spl": [1.0, 0.0, 0.5, 0.5, 0.25, 0.75]})
    maps = pd.DataFrame({"env": "e", "map_seed": [1, 1, 2, 2, 3, 3], "robot": [0, 1] * 3,
                         **{m: [1.0, np.nan, 2.0, 4.0, 9.0, 9.0] for m in MEASURES}})
    got = map_spl(episodes, maps)
    assert got[["map_seed", "policy", "spl", "dispersion"]].to_numpy().tolist() == [
        [1, "p", 0.5, 1.0], [1, "q", 0.5, 1.0], [2, "p", 0.5, 3.0]]
