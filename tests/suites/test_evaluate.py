"""fftnav.suites.evaluate: one method run on a suite beside the references, checked before
they are trusted, ranked and tested against independent computations."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import stats

import fftnav.suites as suites
from fftnav.runner.run import CSV_COLUMNS
from fftnav.runner.summary import holm
from fftnav.suites.evaluate import Options, check_references, evaluate, paired_against
from fftnav.suites.leaderboard import leaderboard_columns, ranking

QUIET = Options(workers=1, progress=False)


def _rows(method, spl_by_map, robots=2):
    """Per-robot rows of one method: map i's robots all have SPL spl_by_map[i]."""
    rows = []
    for i, value in enumerate(spl_by_map):
        for r in range(robots):
            rows.append({**dict.fromkeys(CSV_COLUMNS, 0),
                         "env": "forest" if i % 2 == 0 else "rocky", "map_seed": 10 + i // 2,
                         "policy": method, "robot": r, "arrived": value > 0,
                         "collided": False, "path_length_m": 10.0 / value if value else 5.0,
                         "optimal_length_m": 10.0, "geodesic_length_m": 10.0,
                         "time_s": 20.0 if value else np.nan,
                         "spl": value, "bytes_sent": 3 * r, "failure": "" if value else "stuck"})
    return pd.DataFrame(rows)


def test_ranking_pools_maps_ranks_by_spl_and_tests_against_the_first():
    a = [0.9, 0.8, 0.95, 0.7, 0.85, 0.9]
    b = [0.8, 0.7, 0.9, 0.6, 0.84, 0.4]
    c = [0.9, 0.0, 0.95, 0.7, 0.85, 0.9]
    episodes = pd.concat([_rows("a", a), _rows("b", b), _rows("c", c)], ignore_index=True)
    table = ranking(episodes, None, suite="s")
    assert list(table.columns) == list(leaderboard_columns())
    assert list(table["method"]) == ["a", "c", "b"]
    assert list(table["rank"]) == [1, 2, 3]
    assert table["spl"].tolist() == pytest.approx([np.mean(a), np.mean(c), np.mean(b)])
    assert table.loc[1, "ar"] == pytest.approx(5 / 6)
    assert table.loc[1, "failures_stuck"] == 2  # both robots of c's empty map
    # an independent computation: scipy's exact Wilcoxon on the per-map differences, Holm
    p_c = stats.wilcoxon(np.subtract(a, c)).pvalue
    p_b = stats.wilcoxon(np.subtract(a, b)).pvalue
    assert table["p_holm"].tolist()[1:] == pytest.approx(list(holm([p_c, p_b])))
    assert np.isnan(table["p_holm"].iloc[0])
    assert table["maps"].tolist() == [6, 6, 6]  # forest 10 and rocky 10 are two maps


def test_ties_share_a_rank():
    episodes = pd.concat([_rows("x", [0.5, 0.5]), _rows("y", [0.5, 0.5]),
                          _rows("z", [0.1, 0.2])], ignore_index=True)
    assert ranking(episodes, None, suite="s")["rank"].tolist() == [1, 1, 3]


def test_paired_against_is_holm_adjusted_wilcoxon_of_per_map_spl():
    mine = [0.9, 0.85, 0.95, 0.7, 0.8, 0.9, 0.6, 0.75]
    other1 = [0.8, 0.8, 0.9, 0.72, 0.7, 0.85, 0.5, 0.7]
    other2 = [0.9, 0.85, 0.95, 0.7, 0.8, 0.9, 0.6, 0.75]
    episodes = pd.concat([_rows("me", mine), _rows("o1", other1), _rows("o2", other2)],
                         ignore_index=True)
    tests = paired_against(episodes, "me", suite="s", against=["o1", "o2", "me", "absent"])
    assert tests["against"].tolist() == ["o1", "o2"]
    diff = np.subtract(mine, other1)
    assert tests.loc[0, "mean_diff"] == pytest.approx(diff.mean())
    assert tests.loc[0, "p_value"] == pytest.approx(stats.wilcoxon(diff).pvalue)
    assert np.isnan(tests.loc[1, "p_value"])  # identical on every map: no test
    assert tests.loc[0, "p_holm"] == pytest.approx(tests.loc[0, "p_value"])  # family of one


def test_references_reproduce_and_the_check_names_a_difference(tiny):
    check = check_references(tiny, method="mine")
    assert check.same and check.method == "bug-left"
    assert check.tasks == ("forest-7-bug-left", "forest-8-bug-left")
    assert check.compute_ms_here > 0 and check.compute_ms_shipped > 0
    # another platform: one row differs, its checksum rewritten to match
    folder = suites.references_folder(tiny.name)
    episodes, timing = suites.read_references(tiny)
    episodes.loc[(episodes["policy"] == "bug-left") & (episodes["map_seed"] == 7)
                 & (episodes["robot"] == 1), "path_length_m"] += 0.001
    suites.write_references(tiny, episodes, timing, folder)
    check = check_references(tiny, method="mine")
    assert not check.same
    assert "forest-7-bug-left: robot 1: path_length_m" in check.detail
    assert "do not reproduce here" in check.line
    assert check_references(tiny, method="bug-left").method == "bug-right"


def test_evaluate_ranks_the_method_beside_the_references_and_resumes(tiny, tmp_path):
    out = tmp_path / "eval"
    said = []
    evaluation = evaluate("own-only", ["tiny"], out, options=QUIET, say=said.append)
    assert said[0].startswith("references of tiny-v1 reproduce here")
    result = evaluation.suites[0]
    assert set(result.table["method"]) == {"bug-left", "bug-right", "fusion", "own-only"}
    assert set(result.tests["against"]) == {"bug-left", "bug-right", "fusion"}
    board = pd.read_csv(out / "leaderboard.csv")
    assert list(board.columns) == list(leaderboard_columns())
    info = json.loads((out / "evaluation.json").read_text())
    assert info["method"] == "own-only" and info["method_sha256"].startswith("builtin-")
    assert info["suites"]["tiny-v1"]["reference_checks"][0]["same"] is True
    # the method's own rows are those of its run folder
    mine = pd.read_csv(out / "runs" / "tiny-v1" / "episodes.csv")
    assert set(mine["policy"]) == {"own-only"}
    again = evaluate("own-only", ["tiny"], out, options=QUIET)
    run_info = json.loads((out / "runs" / "tiny-v1" / "run_info.json").read_text())
    assert run_info["tasks_skipped"] == 2 and run_info["tasks_completed"] == 0
    pd.testing.assert_frame_equal(again.table, evaluation.table, check_exact=False)


def test_evaluating_a_builtin_replaces_its_reference_rows(tiny, tmp_path):
    evaluation = evaluate("fusion", ["tiny"], tmp_path / "e", options=QUIET)
    table = evaluation.suites[0].table
    assert table["method"].tolist().count("fusion") == 1
    shipped = suites.read_references(tiny)[0]
    ours = evaluation.suites[0].episodes
    # the same code and seeds: the rerun gives the shipped rows
    cols = ["map_seed", "robot", "spl", "path_length_m"]
    pd.testing.assert_frame_equal(
        ours[ours["policy"] == "fusion"][cols].reset_index(drop=True),
        shipped[shipped["policy"] == "fusion"][cols].reset_index(drop=True))


def test_references_that_do_not_reproduce_are_refused_or_rerun(tiny, tmp_path):
    folder = suites.references_folder(tiny.name)
    episodes, timing = suites.read_references(tiny)
    changed = episodes.copy()
    changed.loc[changed["policy"] == "bug-left", "spl"] *= 0.5
    suites.write_references(tiny, changed, timing, folder)
    with pytest.raises(ValueError, match=r"references of tiny-v1 do not reproduce here "
                       r"\(forest-7-bug-left: robot 0: spl .*\).*--no-rerun refuses"):
        evaluate("own-only", ["tiny"], tmp_path / "a",
                 options=Options(workers=1, progress=False, rerun=False))
    said = []
    evaluation = evaluate("own-only", ["tiny"], tmp_path / "b", options=QUIET,
                          say=said.append)
    assert any(s.startswith("rerunning every built-in on tiny-v1") for s in said)
    table = evaluation.suites[0].table.set_index("method")
    rerun = ranking(episodes, timing, suite="tiny-v1").set_index("method")
    assert table.loc["bug-left", "spl"] == pytest.approx(rerun.loc["bug-left", "spl"])


def test_bad_input_is_refused_before_anything_runs(tiny, tmp_path):
    with pytest.raises(ValueError, match=r"got suite='nope'"):
        evaluate("own-only", ["nope"], tmp_path / "x", options=QUIET)
    with pytest.raises(ValueError, match=r"sample must be an integer >= 1, got sample=0"):
        evaluate("own-only", ["tiny"], tmp_path / "x",
                 options=Options(workers=1, progress=False, sample=0))
    with pytest.raises(ValueError, match=r"did you mean 'own-only'"):
        evaluate("own-onyl", ["tiny"], tmp_path / "x", options=QUIET)
    assert not (tmp_path / "x").exists()
