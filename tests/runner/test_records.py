"""``[record] episodes``: which episodes of an experiment keep their recording, resume, and
that recording changes no result."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest

from fftnav.episode import read_recording
from fftnav.runner import parse_config, run_experiment

BASE = {
    "experiment": {"name": "rec", "envs": ["forest"], "maps": 2, "map_seed": 7, "robots": 3,
                   "policies": ["bug-left", "fusion"]},
    "world": {"size_m": [8.0, 8.0], "goal_y_m": 7.0},
    "episode": {"time_limit_s": 12.5},  # map 7 has robots out of time, map 8 has none
}
CSVS = ("episodes.csv", "summary.csv", "paired_tests.csv")


def _config(mode=None):
    return parse_config({**BASE, **({"record": {"episodes": mode}} if mode else {})})


@pytest.fixture(scope="module")
def failures_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("failures")
    run_experiment(_config(), out, workers=1, progress=False)
    return out


def _failed_tasks(out):
    episodes = pd.read_csv(out / "episodes.csv")
    failed = episodes[~episodes.arrived].groupby(["env", "map_seed", "policy"]).size()
    return {f"{env}-{seed}-{policy}" for env, seed, policy in failed.index}


def test_by_default_exactly_the_episodes_with_a_failure_are_recorded(failures_run):
    failed = _failed_tasks(failures_run)
    assert failed and len(failed) < 4
    assert {p.stem for p in (failures_run / "records").iterdir()} == failed
    episodes = pd.read_csv(failures_run / "episodes.csv", keep_default_na=False)
    for name in failed:
        rec = read_recording(failures_run / "records" / f"{name}.npz")
        env, seed, policy = name.split("-", 2)
        rows = episodes[(episodes.map_seed == int(seed)) & (episodes.policy == policy)]
        assert [r["failure"] for r in rec.rows] == list(rows.failure)
        assert rec.policy == policy and rec.seed == int(rows.episode_seed.iloc[0])


@pytest.mark.parametrize(("mode", "count"), [("all", 4), ("none", 0)])
def test_all_and_none_record_every_or_no_episode_with_the_same_csvs(failures_run, tmp_path,
                                                                    mode, count):
    run_experiment(_config(mode), tmp_path, workers=1, progress=False)
    assert len(list((tmp_path / "records").iterdir())) == count
    for name in CSVS:
        assert (tmp_path / name).read_bytes() == (failures_run / name).read_bytes()


def test_a_resume_reruns_only_the_task_whose_wanted_recording_is_missing(failures_run, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(failures_run, out)
    missing = sorted((out / "records").iterdir())[0]
    missing.unlink()
    outcome = run_experiment(_config(), out, workers=1, progress=False)
    assert (outcome.completed, outcome.skipped) == (1, 3)
    assert missing.exists()
    for name in CSVS:
        assert (out / name).read_bytes() == (failures_run / name).read_bytes()
    # switching the record mode is not a different experiment: nothing is refused or rerun
    outcome = run_experiment(_config("none"), out, workers=1, progress=False)
    assert (outcome.completed, outcome.skipped) == (0, 4)


@pytest.mark.parametrize("damage", ["empty", "cut", "garbage"])
def test_a_resume_reruns_the_task_whose_recording_is_damaged(failures_run, tmp_path, capfd,
                                                            damage):
    out = tmp_path / "resumed"
    shutil.copytree(failures_run, out)
    damaged = sorted((out / "records").iterdir())[0]
    good = damaged.read_bytes()
    damaged.write_bytes({"empty": b"", "cut": good[:len(good) // 2],
                         "garbage": b"PK\x03\x04" + b"\x00" * 64}[damage])
    outcome = run_experiment(_config(), out, workers=1, progress=False)
    assert (outcome.completed, outcome.skipped) == (1, 3)
    assert damaged.read_bytes() == good  # the rerun episode records the same bytes
    err = capfd.readouterr().err
    assert f"rerunning {damaged.stem}: its recording {damaged} cannot be trusted (" in err
    for name in CSVS:
        assert (out / name).read_bytes() == (failures_run / name).read_bytes()


def test_fresh_keeps_only_the_recordings_of_its_own_failures(failures_run, tmp_path):
    """A recording left by an earlier run of a task whose episode now has no failure (here: a
    run with every episode recorded) is removed by --fresh, not kept beside the new results."""
    out = tmp_path / "again"
    run_experiment(_config("all"), out, workers=1, progress=False)
    assert len(list((out / "records").iterdir())) == 4
    run_experiment(_config(), out, workers=1, progress=False, fresh=True)
    assert {p.stem for p in (out / "records").iterdir()} == _failed_tasks(failures_run)


def test_an_unknown_record_mode_or_key_is_refused_by_name():
    with pytest.raises(ValueError, match=r"record.episodes must be one of \['none', "
                                         r"'failures', 'all'\], got record.episodes='some'"):
        _config("some")
    with pytest.raises(ValueError, match=r"unknown key record.keep; expected one of "
                                         r"\['episodes'\]"):
        parse_config({**BASE, "record": {"keep": "all"}})


def test_the_report_places_each_failure_where_its_recording_ends(failures_run):
    from fftnav.report.failures import failure_positions

    positions = failure_positions(failures_run)
    episodes = pd.read_csv(failures_run / "episodes.csv")
    assert len(positions) == int((~episodes.arrived).sum()) > 0
    for r in positions.itertuples(index=False):
        rec = read_recording(failures_run / "records" / f"{r.env}-{r.map_seed}-{r.policy}.npz")
        assert (r.x, r.y) == tuple(rec.pose[-1, r.robot, :2])
        trajectory = failures_run / "trajectories" / f"{r.env}-{r.map_seed}-{r.policy}.npz"
        if trajectory.exists():  # the other source agrees (the recording keeps float32)
            with np.load(trajectory) as paths:
                assert (r.x, r.y) == pytest.approx(tuple(paths[f"arr_{r.robot}"][-1, :2]),
                                                   abs=1e-5)


@pytest.mark.parametrize("name", ["records", "episodes", "reference"])
def test_a_file_where_a_results_folder_goes_is_refused_naming_it(tmp_path, name):
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_text("not a folder")
    with pytest.raises(ValueError, match=rf"^{out / name} must be a folder of the results, got a "
                                         r"file by that name: move it away, or use another "
                                         r"--out$"):
        run_experiment(_config(), out, workers=1, progress=False)
    assert (out / name).read_text() == "not a folder"


def test_a_folder_whose_config_named_files_beside_it_reruns_from_config_json(tmp_path):
    """A config in one folder naming a network by a path relative to it (``learned:``), run
    into a results folder elsewhere: the folder's copy of the config does not resolve there,
    so rerunning a task takes the networks the run resolved (config.json)."""
    from fftnav.navigation.learned import untrained
    from fftnav.runner import load_config
    from fftnav.runner.rerun import rerun_task

    (tmp_path / "experiments").mkdir()
    (tmp_path / "nets").mkdir()
    untrained("extrema", seed=0, hidden=(8,)).save(tmp_path / "nets" / "n.npz")
    config_path = tmp_path / "experiments" / "c.toml"
    config_path.write_text(
        '[experiment]\nname = "rel"\nenvs = ["forest"]\nmaps = 1\nmap_seed = 7\nrobots = 2\n'
        'policies = ["learned:../nets/n.npz"]\n'
        '[world]\nsize_m = [8.0, 8.0]\ngoal_y_m = 7.0\n[episode]\ntime_limit_s = 3.0\n')
    out = tmp_path / "results" / "deep" / "rel"
    run_experiment(load_config(config_path), out, workers=1, progress=False)
    rerun = rerun_task(out, "forest-7-learned-n")
    assert rerun.task.policy == "learned-n"
