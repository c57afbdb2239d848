"""From the report's list of failed robots to the moment of the failure, in headless Chromium:
a real experiment (tests/report/small_results.py, every robot fails), its ``report.md``'s first
failed robot's link ``replays/<task>.html#robot=R&t=T``, the page made on demand by the command
the report gives, opened at that link: robot R picked, the clock at T, paused, the robot shown
failed with the report's cause, and no console error or network request."""

from __future__ import annotations

import re

import pytest

from tests.report.small_results import fftnav, make_small_results
from tests.report.test_replay_browser import _browser, _errors, _open


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    return make_small_results(tmp_path_factory.mktemp("links"))


def test_the_report_s_link_opens_the_replay_at_the_failure(results):
    report = (results / "report.md").read_text()
    row = re.search(r"^\| (\w+) \| (\d+) \| ([\w-]+) \| (\d+) \| (\w+) \| ([\d.]+) s at .*?"
                    r"\[replay\]\((replays/([\w-]+)\.html)#robot=(\d+)&t=([\d.]+)\) \|$",
                    report, re.M)
    assert row, "report.md lists no failed robot with a replay link"
    env, map_seed, policy, robot, cause, time_s, page, task, hash_robot, hash_t = row.groups()
    assert task == f"{env}-{map_seed}-{policy}" and hash_robot == robot and hash_t == time_s
    command = re.search(r"`fftnav replay (\S+) --task ([\w-]+) --out (\S+)/replays/\2\.html`",
                        report)
    assert command, "report.md does not say how to make the replay pages"
    made = fftnav("replay", results, "--task", task, "--out",
                  results / "replays" / f"{task}.html")
    assert made.returncode == 0, made.stderr
    tools = _open(_browser(), results / page, results / "profile", f"#robot={robot}&t={time_s}")
    try:
        state = tools.evaluate("({tick: fftnavPlayer.tick, picked: fftnavPlayer.picked, "
                               "playing: fftnavPlayer.playing, dt: fftnavPlayer.dt || 0.1})")
        assert state["picked"] == int(robot) and state["playing"] is False
        assert abs(state["tick"] * state["dt"] - float(time_s)) <= state["dt"] / 2 + 1e-9
        info = tools.evaluate("document.getElementById('robot-info').textContent")
        assert "did not arrive" in info and cause in info
        clock = tools.evaluate("document.getElementById('clock').textContent")
        assert clock.startswith(f"t = {float(time_s):.1f} s")
        assert not _errors(tools.events)
    finally:
        tools.close()
