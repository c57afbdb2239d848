"""Experiment runner: TOML configs, episode tasks on a process pool or Dask, resumable outputs.

Typical use (what ``fftnav run CONFIG`` does)::

    config = load_config("experiments/smoke.toml")
    outcome = run_experiment(config, "results/smoke", workers=2)
"""

from fftnav.runner.config import ExperimentConfig, load_config, parse_config
from fftnav.runner.executors import EXECUTORS, TaskError, execute
from fftnav.runner.run import CSV_COLUMNS, RunOutcome, run_experiment
from fftnav.runner.summary import bootstrap_ratio_ci, paired_tests, summarize
from fftnav.runner.tasks import Task, TaskResult, make_tasks, run_task

__all__ = [
    "CSV_COLUMNS", "EXECUTORS", "ExperimentConfig", "RunOutcome", "Task", "TaskError",
    "TaskResult", "bootstrap_ratio_ci", "execute", "load_config", "make_tasks", "paired_tests",
    "parse_config", "run_experiment", "run_task", "summarize",
]
