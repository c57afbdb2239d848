"""Runner logic with fake task functions: resume, interruption, crash isolation, determinism."""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np
import pandas as pd
import pytest

from fftnav.episode import EPISODE_COLUMNS, EpisodeRow
from fftnav.runner import CSV_COLUMNS, TaskResult, execute, parse_config, run_experiment
from fftnav.runner.run import TIMING_COLUMNS, read_timing
from fftnav.runner.tasks import iter_tasks

CONFIG = parse_config({
    "experiment": {"name": "fake", "envs": ["forest", "rocky"], "maps": 3, "map_seed": 5,
                   "robots": 3, "policies": ["bug-left", "fusion", "random"]},
}, source="# fake\n")
N_TASKS = 2 * 3 * 3


def fake_task(config, task):
    """Deterministic rows from the task's seeds; later tasks finish first (shuffled order)."""
    time.sleep(0.002 * (task.map_seed % 3))
    rng = np.random.default_rng([task.episode_seed, len(task.policy)])
    rows = [EpisodeRow(**{**{c: rng.uniform(0, 20) for c in EPISODE_COLUMNS}, "robot": r,
                          "policy": task.policy, "arrived": bool(rng.random() < 0.8),
                          "collided": False, "bytes_sent": int(rng.integers(0, 500))})
            for r in range(config.robots)]
    trajectories = [rng.random((4, 3)) for _ in rows] if task.keep_trajectories else None
    return TaskResult(rows, trajectories)


def failing_task(config, task):
    if task.policy == "fusion" and task.map_seed == 6:
        raise RuntimeError(f"boom in {task.task_id}")
    return fake_task(config, task)


class Interrupt:
    """Runs ``fake_task`` but raises KeyboardInterrupt at the ``n``-th call (in-process only)."""

    def __init__(self, n):
        self.calls, self.n = 0, n

    def __call__(self, config, task):
        self.calls += 1
        if self.calls == self.n:
            raise KeyboardInterrupt
        return fake_task(config, task)


def files(out):
    return {p.relative_to(out).as_posix(): p.read_bytes()
            for name in ("episodes.csv", "summary.csv", "paired_tests.csv")
            for p in [out / name]}


def test_episodes_csv_has_one_row_per_robot_per_task(tmp_path):
    outcome = run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    assert (outcome.total, outcome.completed, outcome.skipped, outcome.failed) == (18, 18, 0, [])
    df = pd.read_csv(tmp_path / "episodes.csv")
    assert tuple(df.columns) == CSV_COLUMNS and len(df) == N_TASKS * 3
    assert not df.duplicated(["env", "map_seed", "policy", "robot"]).any()
    assert df.equals(df.sort_values(["env", "map_seed", "policy", "robot"]).reset_index(drop=True))
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert len(summary) == 6 and (summary.episodes == 3).all() and (summary.robots == 9).all()
    assert len(list((tmp_path / "trajectories").glob("*.npz"))) == 2 * 3  # first map of each env
    assert (tmp_path / "config.toml").read_text() == "# fake\n"
    assert not list(tmp_path.rglob("*.tmp"))


def test_results_identical_whatever_the_worker_count(tmp_path):
    run_experiment(CONFIG, tmp_path / "one", workers=1, task_fn=fake_task, progress=False)
    run_experiment(CONFIG, tmp_path / "two", workers=2, task_fn=fake_task, progress=False)
    assert files(tmp_path / "one") == files(tmp_path / "two")


def test_interrupted_run_resumes_to_exactly_the_uninterrupted_rows(tmp_path):
    run_experiment(CONFIG, tmp_path / "full", workers=1, task_fn=fake_task, progress=False)
    out = tmp_path / "resumed"
    with pytest.raises(KeyboardInterrupt):
        run_experiment(CONFIG, out, workers=1, task_fn=Interrupt(8), progress=False)
    partial = pd.read_csv(out / "episodes.csv")  # a complete CSV of the 7 finished tasks
    assert len(partial) == 7 * 3
    (out / ".episodes.csv.999.tmp").write_text("half a row,")  # a writer killed mid-write
    (out / "episodes" / "forest-5-bug-left.csv").unlink()  # a lost result is redone
    outcome = run_experiment(CONFIG, out, workers=2, task_fn=fake_task, progress=False)
    assert (outcome.skipped, outcome.completed) == (6, N_TASKS - 6)
    assert files(out) == files(tmp_path / "full")
    again = run_experiment(CONFIG, out, workers=1, task_fn=failing_task, progress=False)
    assert (again.skipped, again.completed, again.failed) == (N_TASKS, 0, [])
    assert files(out) == files(tmp_path / "full")


def test_a_task_that_raises_is_recorded_and_the_others_complete(tmp_path):
    outcome = run_experiment(CONFIG, tmp_path, workers=2, task_fn=failing_task, progress=False)
    assert sorted(t.task_id for t, _ in outcome.failed) == ["forest-6-fusion", "rocky-6-fusion"]
    assert outcome.completed == N_TASKS - 2
    errors = pd.read_csv(tmp_path / "errors.csv")
    assert list(errors.error_type) == ["RuntimeError"] * 2
    assert list(errors.message) == ["boom in forest-6-fusion", "boom in rocky-6-fusion"]
    assert errors.traceback.str.contains("failing_task").all()
    df = pd.read_csv(tmp_path / "episodes.csv")
    assert len(df) == (N_TASKS - 2) * 3
    assert df[(df.map_seed == 6) & (df.policy == "fusion")].empty
    retry = run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    assert (retry.completed, retry.failed) == (2, []) and not (tmp_path / "errors.csv").exists()


def test_rows_that_are_not_episode_rows_are_a_task_error(tmp_path):
    def dict_rows(config, task):
        result = fake_task(config, task)
        return TaskResult([row.as_dict() for row in result.rows], result.trajectories)

    outcome = run_experiment(CONFIG, tmp_path, workers=1, task_fn=dict_rows, progress=False)
    assert len(outcome.failed) == N_TASKS
    assert "returned rows of type dict, not EpisodeRow" in outcome.failed[0][1].message
    assert len(pd.read_csv(tmp_path / "episodes.csv")) == 0


def test_folder_of_another_experiment_is_refused(tmp_path):
    run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    other = parse_config({"experiment": {"name": "fake", "envs": ["forest"], "maps": 3,
                                         "map_seed": 5, "robots": 3, "policies": ["fusion"]}})
    with pytest.raises(ValueError, match=r"holds results of a different experiment config"):
        run_experiment(other, tmp_path, workers=1, task_fn=fake_task, progress=False)


def test_folder_written_with_other_columns_is_refused_naming_them(tmp_path):
    run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    record = tmp_path / "config.json"
    data = json.loads(record.read_text())
    data["csv_columns"] = [c for c in data["csv_columns"] if c != "spl"] + ["colour"]
    record.write_text(json.dumps(data, indent=1, sort_keys=True))
    with pytest.raises(ValueError, match=r"holds episodes with other columns than this fftnav "
                       r"writes \(missing \['spl'\], extra \['colour'\]\)"):
        run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    # a config.json without csv_columns: the header of episodes.csv is checked
    del data["csv_columns"]
    record.write_text(json.dumps(data, indent=1, sort_keys=True))
    episodes = tmp_path / "episodes.csv"
    header, rest = episodes.read_text().split("\n", 1)
    episodes.write_text(header.replace(",robot_contacts", "") + "\n" + rest)
    with pytest.raises(ValueError, match=r"missing \['robot_contacts'\], extra \[\]"):
        run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)


@pytest.mark.parametrize("options, match", [
    ({"executor": "spark"}, r"executor must be one of \['local', 'dask'\], got executor='spark'"),
    ({"workers": 0}, r"workers must be an integer >= 1, got workers=0"),
    ({"scheduler": "tcp://x:8786"}, r"scheduler needs executor='dask', got executor='local'"),
])
def test_executor_options_are_validated(options, match):
    with pytest.raises(ValueError, match=match):
        next(execute(fake_task, CONFIG, [], **options))


def test_fresh_reruns_and_replaces_every_task(tmp_path):
    def stale(config, task):
        result = fake_task(config, task)
        return TaskResult([dataclasses.replace(row, spl=0.0) for row in result.rows],
                          result.trajectories)

    run_experiment(CONFIG, tmp_path / "full", workers=1, task_fn=fake_task, progress=False)
    out = tmp_path / "fresh"
    run_experiment(CONFIG, out, workers=1, task_fn=stale, progress=False)
    outcome = run_experiment(CONFIG, out, workers=1, task_fn=fake_task, progress=False,
                             fresh=True)
    assert (outcome.skipped, outcome.completed) == (0, N_TASKS)
    assert files(out) == files(tmp_path / "full")


def test_reference_lengths_are_computed_once_per_map_and_reused(tmp_path, monkeypatch):
    from pathlib import Path

    from fftnav.episode import loop
    from fftnav.optimal.reference import optimal_lengths
    from fftnav.runner import load_config
    from fftnav.runner.tasks import task_world

    config = load_config(Path(__file__).parents[2] / "experiments" / "smoke.toml")
    calls = []
    real = loop.optimal_lengths
    monkeypatch.setattr(loop, "optimal_lengths", lambda *a, **k: calls.append(1) or real(*a, **k))
    loop._reference_lengths.cache_clear()
    run_experiment(config, tmp_path, workers=1, progress=False)  # in-process: calls are seen
    assert calls == []  # no episode computed its own reference lengths
    episodes = pd.read_csv(tmp_path / "episodes.csv")
    for seed in (7, 8):  # oracle: the lengths of the generated map, computed here
        astar, geodesic = optimal_lengths(task_world(config, "forest", seed),
                                          r0_m=config.swarm.robot.r0_m)
        stored = np.load(tmp_path / "reference" / f"forest-{seed}.npy")
        assert stored.tobytes() == np.array([astar, geodesic]).tobytes()
        for policy in ("bug-left", "fusion"):
            rows = episodes[(episodes.map_seed == seed) & (episodes.policy == policy)]
            np.testing.assert_allclose(rows.optimal_length_m, astar, atol=5e-7)  # %.6f
            np.testing.assert_allclose(rows.geodesic_length_m, geodesic, atol=5e-7)
    before = files(tmp_path)
    (tmp_path / "reference" / "forest-8.npy").unlink()
    run_experiment(config, tmp_path, workers=1, progress=False, fresh=True)
    assert files(tmp_path) == before and (tmp_path / "reference" / "forest-8.npy").exists()


def _recorded_episodes(monkeypatch, events, *, stop_after=None, started=None):
    """Real tasks (:func:`run_task`) with a fake episode and fake reference lengths, both
    recorded in ``events`` in call order; the episode checks it got its map's lengths."""
    import types

    from fftnav.runner import run as run_module
    from fftnav.runner import tasks as tasks_module

    def lengths(task):
        return np.full((2, 3), float(task.map_seed))

    def reference(config, task):
        events.append(("reference", task.env, task.map_seed))
        return lengths(task)

    def episode(world, policy, *, seed, config, reference, record):
        env, map_seed = world
        events.append(("episode", env, map_seed))
        if started is not None:
            started.append(time.perf_counter())
        assert np.array_equal(np.array(reference), np.full((2, 3), float(map_seed)))
        if stop_after is not None and sum(e[0] == "episode" for e in events) >= stop_after:
            raise KeyboardInterrupt
        rows = [EpisodeRow(**{**dict.fromkeys(EPISODE_COLUMNS, 1.0), "robot": r,
                              "policy": policy, "arrived": True, "collided": False,
                              "bytes_sent": 0, "failure": ""}) for r in range(3)]
        return types.SimpleNamespace(rows=rows, trajectories=[np.zeros((2, 3))] * 3,
                                     failed=False, compute_s=0.5, robot_ticks=10)

    monkeypatch.setattr(run_module, "map_reference", reference)
    monkeypatch.setattr(run_module, "write_maps_csv", lambda *a, **k: None)
    monkeypatch.setattr(tasks_module, "task_world", lambda config, env, seed: (env, seed))
    monkeypatch.setattr(tasks_module, "run_episode", episode)


def test_reference_lengths_are_computed_a_batch_of_maps_just_before_its_episodes(
        tmp_path, monkeypatch):
    from fftnav.runner import run as run_module

    events = []
    _recorded_episodes(monkeypatch, events)
    monkeypatch.setattr(run_module, "REFERENCE_BATCH_MAPS", 2)
    outcome = run_experiment(CONFIG, tmp_path, workers=1, progress=False)
    assert (outcome.completed, outcome.failed) == (N_TASKS, [])
    maps = [("forest", 5), ("forest", 6), ("forest", 7), ("rocky", 5), ("rocky", 6),
            ("rocky", 7)]
    expected = []
    for batch in (maps[:2], maps[2:4], maps[4:]):
        expected += [("reference", *m) for m in batch]
        expected += [("episode", *m) for m in batch for _ in range(3)]
    assert events == expected
    # a rerun skips every task and computes nothing
    events.clear()
    assert run_experiment(CONFIG, tmp_path, workers=1, progress=False).skipped == N_TASKS
    assert events == []


def test_many_maps_start_their_first_episodes_after_one_batch(tmp_path, monkeypatch):
    """The first episodes of 10,000 maps wait for the reference lengths of 256 maps only (the
    same holds for a million maps, where interrupting costs more: the rebuild of
    episodes.csv checks every task's file)."""
    events, started = [], []
    _recorded_episodes(monkeypatch, events, stop_after=2, started=started)
    config = parse_config({"experiment": {"name": "many", "envs": ["forest"],
                                          "maps": 10_000, "map_seed": 0, "robots": 3,
                                          "policies": ["bug-left", "fusion"]}})
    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        run_experiment(config, tmp_path, workers=1, progress=False)
    assert started[0] - start < 30
    references = [e for e in events if e[0] == "reference"]
    assert references == [("reference", "forest", seed) for seed in range(256)]
    assert events[256:] == [("episode", "forest", 0)] * 2


def test_run_info_config_json_and_report_say_the_fftnav_that_ran(tmp_path, monkeypatch):
    """The version comes from the running package (``fftnav.__version__``), not from the
    install's metadata, which an editable install keeps from when it was installed."""
    import fftnav
    from fftnav.report.experiment import write_report

    monkeypatch.setattr(fftnav, "__version__", "9.8.7")
    run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    assert json.loads((tmp_path / "run_info.json").read_text())["fftnav_version"] == "9.8.7"
    assert json.loads((tmp_path / "config.json").read_text())["fftnav_version"] == "9.8.7"
    assert "fftnav 9.8.7, git" in write_report(CONFIG, tmp_path).read_text()


def test_each_task_s_compute_goes_to_timing_csv_and_nowhere_else(tmp_path, monkeypatch):
    """timing.csv holds each finished task's compute (the fake episodes report 0.5 s over 10
    robot-ticks: 50 ms each), in task order; a rerun that skips every task keeps it."""
    events = []
    _recorded_episodes(monkeypatch, events)
    run_experiment(CONFIG, tmp_path, workers=1, progress=False)
    timing = pd.read_csv(tmp_path / "timing.csv")
    assert list(timing.columns) == list(TIMING_COLUMNS)
    assert len(timing) == N_TASKS
    assert list(zip(timing.env, timing.map_seed, timing.policy, strict=True)) == [
        (t.env, t.map_seed, t.policy) for t in iter_tasks(CONFIG)]
    assert (timing.compute_ms == 50.0).all() and (timing.robot_ticks == 10).all()
    assert "compute" not in (tmp_path / "episodes.csv").read_text().splitlines()[0]
    before = (tmp_path / "timing.csv").read_bytes()
    run_experiment(CONFIG, tmp_path, workers=1, progress=False)
    assert (tmp_path / "timing.csv").read_bytes() == before
    assert read_timing(tmp_path / "nowhere").empty
