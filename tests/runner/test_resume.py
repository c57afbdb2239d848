"""A results folder is trusted only for files that pass a check; one run per folder; no stale
temporaries; killed runs' time counted; tasks enumerated lazily with O(1) bookkeeping."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from fftnav.config import PlannerConfig
from fftnav.plugins import file_sha256
from fftnav.runner import parse_config, run_experiment
from fftnav.runner.resume import FolderLock, InvocationClock
from fftnav.runner.tasks import iter_tasks, make_tasks, task_count
from tests.runner.test_run import CONFIG, N_TASKS, Interrupt, fake_task, files

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def full(tmp_path):
    out = tmp_path / "full"
    run_experiment(CONFIG, out, workers=1, task_fn=fake_task, progress=False)
    return out


@pytest.mark.parametrize(("damage", "why"), [
    (b"", "empty"),
    (b"\x93garbage\n", "not UTF-8 text"),
    (b"a,b,c\n", "1 rows, expected 3"),
    ("TRUNCATE", "its last line is incomplete"),
    ("OTHER", "row 1 belongs to another episode or robot"),
])
def test_a_damaged_episode_file_is_rerun_naming_it(full, tmp_path, capsys, damage, why):
    out = tmp_path / "damaged"
    run_experiment(CONFIG, out, workers=1, task_fn=fake_task, progress=False)
    path = out / "episodes" / "forest-6-fusion.csv"
    if damage == "TRUNCATE":
        damage = path.read_bytes()[:-40]
    elif damage == "OTHER":
        damage = (out / "episodes" / "forest-7-fusion.csv").read_bytes()
    path.write_bytes(damage)
    capsys.readouterr()
    outcome = run_experiment(CONFIG, out, workers=1, task_fn=fake_task, progress=False)
    err = capsys.readouterr().err
    assert (outcome.skipped, outcome.completed) == (N_TASKS - 1, 1)
    assert f"rerunning forest-6-fusion: {path} cannot be trusted ({why}" in err
    assert files(out) == files(full)


def test_damaged_trajectories_are_rerun(full, tmp_path, capsys):
    out = tmp_path / "npz"
    run_experiment(CONFIG, out, workers=1, task_fn=fake_task, progress=False)
    npz = out / "trajectories" / "rocky-5-random.npz"
    npz.write_bytes(npz.read_bytes()[:100])
    outcome = run_experiment(CONFIG, out, workers=1, task_fn=fake_task, progress=False)
    assert outcome.completed == 1 and "rocky-5-random.npz are damaged" in capsys.readouterr().err
    assert files(out) == files(full)


def test_a_folder_with_episodes_but_no_config_json_is_refused(full):
    (full / "config.json").unlink()
    other = parse_config({"experiment": {"name": "other", "envs": ["forest"], "maps": 1,
                                         "map_seed": 5, "robots": 3, "policies": ["fusion"]}})
    with pytest.raises(ValueError, match=r"holds episode files but no config\.json"):
        run_experiment(other, full, workers=1, task_fn=fake_task, progress=False)
    run_experiment(other, full, workers=1, task_fn=fake_task, progress=False, fresh=True)
    assert sorted(p.name for p in (full / "episodes").iterdir()) == ["forest-5-fusion.csv"]


def test_one_run_per_folder(tmp_path):
    with FolderLock(tmp_path):
        with pytest.raises(ValueError, match=rf"{tmp_path} is in use by another fftnav run "
                                             rf"\(pid {os.getpid()}\)"):
            run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    assert not (tmp_path / ".lock").exists()


def test_stale_temporaries_are_removed_and_none_is_left(full, tmp_path):
    for sub in ("", "episodes", "trajectories", "records", "timing"):
        (full / sub).mkdir(exist_ok=True)
        (full / sub / ".x.csv.123.tmp").write_text("half")
    (full / "figures" / "failures").mkdir(parents=True, exist_ok=True)
    (full / "figures" / ".spl_apl.png.4567.tmp.png").write_text("half an image")
    (full / "figures" / "failures" / ".f.png.4567.tmp.png").write_text("half an image")
    (full / "figures" / "notes.tmp").write_text("a user's file, not ours")
    run_experiment(CONFIG, full, workers=1, task_fn=fake_task, progress=False)
    assert not [p for p in full.rglob(".*.tmp*")]
    assert (full / "figures" / "notes.tmp").exists()
    with pytest.raises(KeyboardInterrupt):
        run_experiment(CONFIG, tmp_path / "i", workers=1, task_fn=Interrupt(3), progress=False)
    assert not list((tmp_path / "i").rglob("*.tmp"))


def test_killed_runs_time_is_counted(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        run_experiment(CONFIG, tmp_path, workers=1, task_fn=Interrupt(5), progress=False)
    marker, = tmp_path.glob(".invocation-*.json")
    start = json.loads(marker.read_text())["start"]
    os.utime(marker, (start + 100.0, start + 100.0))  # as if it had run 100 s
    outcome = run_experiment(CONFIG, tmp_path, workers=1, task_fn=fake_task, progress=False)
    info = json.loads((tmp_path / "run_info.json").read_text())
    assert info["wall_time_total_s"] == pytest.approx(100.0 + outcome.wall_time_s, abs=0.01)
    assert not list(tmp_path.glob(".invocation-*"))
    # a clean clock: no marker means nothing to add
    clock = InvocationClock(tmp_path)
    assert clock.begin() == 0.0
    clock.end()


def test_tasks_are_enumerated_lazily_in_the_sorted_order():
    assert list(iter_tasks(CONFIG)) == sorted(make_tasks(CONFIG))
    assert task_count(CONFIG) == N_TASKS
    huge = parse_config({"experiment": {"name": "huge", "envs": ["forest", "rocky"],
                                        "maps": 1_000_000, "map_seed": 0, "robots": 3,
                                        "policies": ["fusion", "bug-left"]}})
    tic = time.perf_counter()
    first = next(iter_tasks(huge))
    assert time.perf_counter() - tic < 0.5 and first.task_id == "forest-0-bug-left"
    assert task_count(huge) == 4_000_000
    with pytest.raises(ValueError, match=r"episodes \(envs x maps x policies\): 20,000,000 "
                                         r"estimated, above the limit of 10,000,000"):
        parse_config({"experiment": {"name": "h", "envs": ["forest", "rocky"],
                                     "maps": 10_000_000, "map_seed": 0, "robots": 3,
                                     "policies": ["fusion"]}})


_BOOKKEEPING = """
import json, pathlib, sys, tracemalloc
import fftnav.runner.run as run_module
from fftnav.runner import parse_config, run_experiment
from tests.runner.test_run import Interrupt
out = pathlib.Path(sys.argv[1])
big = parse_config({"experiment": {"name": "big", "envs": ["forest"], "maps": 50_000,
                                   "map_seed": 0, "robots": 3, "policies": ["fusion"],
                                   "trajectory_maps": 0}})
rebuilds = []
write = run_module._write_episodes
run_module._write_episodes = lambda folder, config: rebuilds.append(1) or write(folder, config)
for name, stop in (("warm", 3), ("big", 61)):  # one-time costs (imports, caches) paid first
    rebuilds.clear()
    tracemalloc.start()
    try:
        run_experiment(big, out / name, workers=1, task_fn=Interrupt(stop), progress=False)
    except KeyboardInterrupt:
        pass
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
print(json.dumps({"peak": peak, "rebuilds": len(rebuilds)}))
"""


def test_bookkeeping_per_finished_episode_is_constant(tmp_path):
    """50,000 maps, interrupted after 60 episodes: tasks are never all in memory and
    episodes.csv is not rebuilt after every episode. Measured in a fresh interpreter: threads
    that other tests leave running (Dask's event loop) allocate in this one."""
    proc = subprocess.run([sys.executable, "-c", _BOOKKEEPING, str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    measured = json.loads(proc.stdout.splitlines()[-1])
    assert len(pd.read_csv(tmp_path / "big" / "episodes.csv")) == 60 * 3
    assert measured["rebuilds"] <= 3  # the final one, and one per 2 s at most
    assert measured["peak"] < 1e6  # the list of 50,000 tasks alone takes 9 MB


def test_damaged_config_json_is_refused_naming_it_and_damaged_run_info_is_replaced(full):
    (full / "run_info.json").write_bytes(b"\x93{not json")
    outcome = run_experiment(CONFIG, full, workers=1, task_fn=fake_task, progress=False)
    assert outcome.skipped == N_TASKS
    info = json.loads((full / "run_info.json").read_text())
    assert info["wall_time_total_s"] == pytest.approx(outcome.wall_time_s, abs=0.01)
    (full / "config.json").write_bytes(b"\x93\x00garbage")
    with pytest.raises(ValueError, match=rf"^{full} holds a damaged config\.json "
                                         rf"\({full / 'config.json'}\); rerun with --fresh"):
        run_experiment(CONFIG, full, workers=1, task_fn=fake_task, progress=False)


def test_a_changed_config_is_refused_naming_its_keys_and_fresh_reruns_it_from_scratch(
        full, tmp_path):
    data = {"experiment": {"name": "fake", "envs": ["forest", "rocky"], "maps": 2, "map_seed": 5,
                           "robots": 3, "policies": ["fusion", "random"]},
            "episode": {"time_limit_s": 30.0}}
    other = parse_config(data)
    (full / "cell").mkdir()  # what is not the run's own output stays untouched
    (full / "cell" / "episodes.csv").write_text("kept\n")
    (full / "notes.txt").write_text("kept\n")
    with pytest.raises(ValueError, match=rf"^{full} holds results of a different experiment "
                       rf"config \({full / 'config.json'}\); changed: experiment\.maps, "
                       r"experiment\.policies, episode\.time_limit_s; rerun with --fresh"):
        run_experiment(other, full, workers=1, task_fn=fake_task, progress=False)
    outcome = run_experiment(other, full, workers=1, task_fn=fake_task, progress=False,
                             fresh=True)
    assert (outcome.skipped, outcome.completed) == (0, 2 * 2 * 2)
    clean = tmp_path / "clean"
    run_experiment(other, clean, workers=1, task_fn=fake_task, progress=False)
    assert files(full) == files(clean)
    for sub in ("episodes", "trajectories"):  # the old config's files are gone
        assert sorted(p.name for p in (full / sub).iterdir()) == sorted(
            p.name for p in (clean / sub).iterdir())
    assert (full / "cell" / "episodes.csv").read_text() == "kept\n"
    assert (full / "notes.txt").read_text() == "kept\n"


@pytest.fixture
def newcomer(tmp_path):
    """A decision policy in a folder of its own that imports the module beside it."""
    folder = tmp_path / "newcomer"
    folder.mkdir()
    (folder / "newcomer_sides.py").write_text("LEFT = 1\n")
    (folder / "newcomer_policy.py").write_text(
        "from newcomer_sides import LEFT\n\n\ndef mine(context):\n    return LEFT\n")
    yield folder
    sys.modules.pop("newcomer_sides", None)


def test_a_changed_plugin_or_module_beside_it_is_named_and_fresh_reruns(newcomer, tmp_path):
    config = parse_config({"experiment": {
        "name": "mine", "envs": ["forest"], "maps": 2, "map_seed": 5, "robots": 3,
        "policies": ["fusion", f"{newcomer / 'newcomer_policy.py'}:mine"]}})
    out = tmp_path / "mine"
    run_experiment(config, out, workers=1, task_fn=fake_task, progress=False)
    for name in ("newcomer_policy.py", "newcomer_sides.py"):
        edited = newcomer / name
        text = edited.read_text()
        edited.write_text(text + "# edited\n")
        with pytest.raises(ValueError, match=rf"; changed: plugin file {edited.resolve()}; "
                                             r"rerun with --fresh"):
            run_experiment(config, out, workers=1, task_fn=fake_task, progress=False)
        edited.write_text(text)
    outcome = run_experiment(config, out, workers=1, task_fn=fake_task, progress=False)
    assert (outcome.skipped, outcome.completed) == (4, 0)
    (newcomer / "newcomer_sides.py").write_text("LEFT = -1\n")
    outcome = run_experiment(config, out, workers=1, task_fn=fake_task, progress=False,
                             fresh=True)
    assert (outcome.skipped, outcome.completed) == (0, 4)
    recorded = json.loads((out / "config.json").read_text())["plugin_sha256"]
    assert recorded == {f"../newcomer/{n}": file_sha256(newcomer / n)
                        for n in ("newcomer_policy.py", "newcomer_sides.py")}


def test_a_tree_of_results_and_plugin_moved_elsewhere_resumes_as_it_is(newcomer, tmp_path):
    """config.json names the plugin files relative to the results folder (their contents by
    hash), so a copy of the whole tree at another path (another clone, another machine's mount)
    holds the same config.json and resumes without --fresh; a folder whose config.json names
    them by absolute paths (written before) is the same experiment too, and is rewritten."""
    import shutil

    from fftnav.runner.resume import canonical_config
    from fftnav.runner.run import CSV_COLUMNS

    def config_at(folder):
        return parse_config({"experiment": {
            "name": "mine", "envs": ["forest"], "maps": 2, "map_seed": 5, "robots": 3,
            "policies": ["fusion", "newcomer_policy.py:mine"]}}, base=folder)

    out = tmp_path / "newcomer" / "results"
    run_experiment(config_at(newcomer), out, workers=1, task_fn=fake_task, progress=False)
    stored = json.loads((out / "config.json").read_text())
    assert stored["policies"] == ["fusion", "../newcomer_policy.py:mine"]
    moved = tmp_path / "elsewhere" / "deeper"
    shutil.copytree(newcomer, moved)
    sys.modules.pop("newcomer_sides", None)  # a new process would import the moved copy
    outcome = run_experiment(config_at(moved), moved / "results", workers=1, task_fn=fake_task,
                             progress=False)
    assert (outcome.skipped, outcome.completed) == (4, 0)
    assert (moved / "results" / "config.json").read_bytes() == (out / "config.json").read_bytes()
    absolute = canonical_config(config_at(moved), CSV_COLUMNS)
    assert str(moved / "newcomer_policy.py") in absolute
    (moved / "results" / "config.json").write_text(absolute)
    outcome = run_experiment(config_at(moved), moved / "results", workers=1, task_fn=fake_task,
                             progress=False)
    assert (outcome.skipped, outcome.completed) == (4, 0)
    assert (moved / "results" / "config.json").read_bytes() == (out / "config.json").read_bytes()



def test_a_planner_table_is_in_config_json_only_when_it_changes_a_constant(full):
    """Folders run with the default planner keep their config.json (no ``planner`` key); a
    changed ``[planner]`` constant is a different experiment, named by its key."""
    stored = json.loads((full / "config.json").read_text())
    assert "planner" not in stored["swarm"] and "episode" in stored["swarm"]
    experiment = {"name": "fake", "envs": ["forest", "rocky"], "maps": 3, "map_seed": 5,
                  "robots": 3, "policies": ["bug-left", "fusion", "random"]}
    default = PlannerConfig().heading_tol_deg
    same = parse_config({"experiment": experiment, "planner": {"heading_tol_deg": default}})
    assert run_experiment(same, full, workers=1, task_fn=fake_task,
                          progress=False).skipped == N_TASKS
    other = parse_config({"experiment": experiment, "planner": {"heading_tol_deg": 45}})
    with pytest.raises(ValueError, match=r"changed: planner\.heading_tol_deg; rerun with --fresh"):
        run_experiment(other, full, workers=1, task_fn=fake_task, progress=False)
    run_experiment(other, full, workers=1, task_fn=fake_task, progress=False, fresh=True)
    stored = json.loads((full / "config.json").read_text())
    assert stored["swarm"]["planner"]["heading_tol_deg"] == 45.0
