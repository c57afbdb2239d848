"""Bring your own policy: the README's controller, written outside the repository and named in a
TOML config by its file path, runs through ``fftnav run`` into summary.csv and report.md; bad
names and changed plugins are refused in one line before any episode."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
SECTION = re.search(r"## Benchmark your own method\n(.*?)\n## ",
                    (ROOT / "README.md").read_text(), re.S).group(1)


def fftnav(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    """The README's plugin and config in a folder outside the repository."""
    where = tmp_path_factory.mktemp("mine")
    (where / "my_controller.py").write_text(re.search(r"```python\n(.*?)```", SECTION, re.S)[1])
    (where / "mine.toml").write_text(re.search(r"```toml\n(.*?)```", SECTION, re.S)[1])
    return where


@pytest.mark.slow
def test_the_readme_controller_runs_into_the_summary_and_the_report(project):
    proc = fftnav("run", "mine.toml", "--out", "mine", "--workers", "1", "--quiet", cwd=project)
    assert proc.returncode == 0, proc.stderr
    out = project / "mine"
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary.policy) == ["bug-left", "fusion", "safe-greedy"]
    episodes = pd.read_csv(out / "episodes.csv")
    mine = episodes[episodes.policy == "safe-greedy"]
    assert len(mine) == 2 * 3 and (mine.bytes_sent == 0).all()
    assert mine.arrived.sum() == 2  # as the README says: a naive controller
    assert summary.set_index("policy").spl["safe-greedy"] == pytest.approx(mine.spl.mean(),
                                                                           abs=1e-6)
    assert "| forest | safe-greedy |" in (out / "report.md").read_text()
    assert (out / "episodes" / "forest-7-safe-greedy.csv").exists()

    # resuming with a changed plugin file is refused, naming the folder; nothing is rerun
    plugin = project / "my_controller.py"
    plugin.write_text(plugin.read_text().replace("0.05", "0.06"))
    again = fftnav("run", "mine.toml", "--out", "mine", "--quiet", cwd=project)
    assert again.returncode == 2
    assert again.stderr.count("\n") == 1 and "different experiment config" in again.stderr


@pytest.mark.parametrize(("reference", "match"), [
    ("teleport", r"experiment\.policies: policy must be a registered policy or controller "
                 r"\('bug-left', .*\) or module:attr or path/to/file\.py:attr, got "
                 r"policy='teleport'$"),
    ("missing.py:X", r"experiment\.policies: cannot load '.*missing\.py:X': no such file"),
    ("my_controller.py:Nope", r"has no attribute 'Nope'"),
])
def test_bad_policies_are_refused_before_any_episode(project, reference, match):
    config = (project / "mine.toml").read_text().replace('"my_controller.py:SafeGreedy"',
                                                         f'"{reference}"')
    (project / "bad.toml").write_text(config)
    proc = fftnav("run", "bad.toml", "--out", "bad", "--quiet", cwd=project)
    assert proc.returncode == 2 and not (project / "bad").exists()
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("fftnav run: error: ")
    assert re.search(match, proc.stderr)


def test_episode_refuses_a_bad_policy_before_reading_the_world(project):
    proc = fftnav("episode", "--world", "no-such-world.json", "--policy", "nope.py:X",
                  cwd=project)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
    assert "cannot load 'nope.py:X': no such file" in proc.stderr


NEWCOMER_CONFIG = """\
[experiment]
name = "order"
envs = ["rocky", "forest"]
maps = 1
map_seed = 7
robots = 3
policies = ["own-only", "plugins/mine.py:mine", "bug-left"]

[world]
size_m = [8.0, 8.0]
goal_y_m = 7.0

[episode]
time_limit_s = 30.0
"""


@pytest.fixture(scope="module")
def newcomer(tmp_path_factory) -> Path:
    """A newcomer's decision policy in ``plugins/``, importing ``helpers.py`` beside it, and a
    config listing it between two built-in policies (neither in alphabetical order)."""
    where = tmp_path_factory.mktemp("newcomer")
    (where / "plugins").mkdir()
    (where / "plugins" / "helpers.py").write_text("def side(context):\n    return 1\n")
    (where / "plugins" / "mine.py").write_text(
        "from helpers import side\n\n\ndef mine(context):\n    return side(context)\n")
    (where / "order.toml").write_text(NEWCOMER_CONFIG)
    return where


@pytest.mark.slow
def test_a_plugin_importing_its_neighbour_runs_in_order_and_fresh_reruns_it(newcomer):
    proc = fftnav("run", "order.toml", "--out", "res", "--workers", "2", "--quiet", cwd=newcomer)
    assert proc.returncode == 0, proc.stderr
    order = [(env, p) for env in ("rocky", "forest") for p in ("own-only", "mine", "bug-left")]
    summary = pd.read_csv(newcomer / "res" / "summary.csv")
    assert list(zip(summary.env, summary.policy, strict=True)) == order
    report = (newcomer / "res" / "report.md").read_text()
    results = report[:report.index("## Paired tests")]  # the table beside the paper's
    rows = re.findall(r"^\| (rocky|forest) \| ([\w-]+) \|", results, re.M)
    assert rows == order
    episodes = pd.read_csv(newcomer / "res" / "episodes.csv")
    mine = episodes[episodes.policy == "mine"]
    assert len(mine) == 2 * 3 and (mine.decisions_right == 0).all()  # helpers.side: always left

    helpers = newcomer / "plugins" / "helpers.py"
    helpers.write_text("def side(context):\n    return -1\n")
    again = fftnav("run", "order.toml", "--out", "res", "--quiet", cwd=newcomer)
    assert again.returncode == 2 and again.stderr.count("\n") == 1
    assert f"changed: plugin file {helpers.resolve()}; rerun with --fresh" in again.stderr
    fresh = fftnav("run", "order.toml", "--out", "res", "--workers", "2", "--quiet", "--fresh",
                   cwd=newcomer)
    assert fresh.returncode == 0, fresh.stderr
    assert fresh.stdout.startswith("6 episodes run, 0 already done, 0 failed")
    episodes = pd.read_csv(newcomer / "res" / "episodes.csv")
    assert (episodes[episodes.policy == "mine"].decisions_left == 0).all()


@pytest.mark.slow
def test_episode_runs_a_plugin_importing_its_neighbour_and_says_how_it_went(newcomer):
    world = fftnav("world", "generate", "--env", "forest", "--seed", "3", "--size", "8", "8",
                   "--robots", "3", "--out", "w.json", cwd=newcomer)
    assert world.returncode == 0, world.stderr
    proc = fftnav("episode", "--world", "w.json", "--policy", "plugins/mine.py:mine",
                  "--set", "time_limit_s=30", "--out", "e.csv", cwd=newcomer)
    assert proc.returncode == 0, proc.stderr
    rows = pd.read_csv(newcomer / "e.csv")
    assert list(rows.policy) == ["mine"] * 3
    arrived, collided = int(rows.arrived.sum()), int(rows.collided.sum())
    line = proc.stderr.splitlines()[-1]
    head, _, named = line.partition("; failed: ")
    assert head == (f"{arrived}/3 arrived, SPL {rows.spl.mean():.2f}, {collided} collided, "
                    f"{3 - arrived - collided} timed out")
    failed = rows[~rows.arrived]
    assert named == "" if failed.empty else named.startswith(f"{failed.robot.iloc[0]} (")
    for r in failed.itertuples():  # a collision also says when: "(collision at T s)"
        assert re.search(rf"(^|, ){r.robot} \({r.failure}( at [\d.]+ s)?\)", named), line


CRASHING = """\
from fftnav.navigation.controllers import Controller


class InInit(Controller):
    def __init__(self, setup):
        raise RuntimeError("cannot start")


class InAct(Controller):
    uses_pipeline = False

    def act(self, obs):
        return {"v": 0.1, "w": 0.0} if obs.robot else 1 / 0
"""


@pytest.mark.parametrize(("attr", "line", "what"), [
    ("InInit", 6, "InInit.__init__ raised RuntimeError: cannot start"),
    ("InAct", 13, "InAct.act raised ZeroDivisionError: division by zero"),
])
def test_what_a_plugin_raises_is_one_line_in_episode_and_in_run(tmp_path, attr, line, what):
    """``fftnav episode``: that line and exit status 2; ``fftnav run``: one line per failed
    episode and errors.csv, exit status 1."""
    (tmp_path / "crash.py").write_text(CRASHING)
    assert fftnav("world", "generate", "--env", "forest", "--seed", "3", "--size", "8", "8",
                  "--robots", "3", "--out", "w.json", cwd=tmp_path).returncode == 0
    expected = f"plugin 'crash.py:{attr}': {what} (at {tmp_path / 'crash.py'}:{line})"
    proc = fftnav("episode", "--world", "w.json", "--policy", f"crash.py:{attr}",
                  "--out", "e.csv", cwd=tmp_path)
    assert (proc.returncode, proc.stdout) == (2, "")
    assert proc.stderr == f"fftnav episode: error: {expected}\n"
    assert not (tmp_path / "e.csv").exists()
    (tmp_path / "crash.toml").write_text(NEWCOMER_CONFIG.replace(
        '["own-only", "plugins/mine.py:mine", "bug-left"]', f'["crash.py:{attr}"]').replace(
        '["rocky", "forest"]', '["forest"]'))
    run = fftnav("run", "crash.toml", "--out", "res", "--quiet", cwd=tmp_path)
    assert run.returncode == 1
    expected = expected.replace("'crash.py:", f"'{tmp_path / 'crash.py'}:")  # from its config
    assert run.stderr == f"fftnav run: forest-7-{attr} failed: PluginError: {expected}\n"
    errors = pd.read_csv(tmp_path / "res" / "errors.csv")
    assert list(errors.message) == [expected] and list(errors.error_type) == ["PluginError"]
