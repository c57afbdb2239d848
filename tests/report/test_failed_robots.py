"""The list of failed robots (fftnav.report.failures.failed_robots): the time and place of each
failure read from the hand-made recording of tests/report/recordings.py, whose story is the
oracle (robot 3 touches the trunk during tick 30, standing at (8, 4); robot 2 runs out of time
at the end tick, 6.0 s), and the reason given for every robot without a recording."""

from __future__ import annotations

import csv
import shutil

import pandas as pd
import pytest

from fftnav.report.experiment import write_report
from fftnav.report.failures import (
    FAILED_COLUMNS,
    failed_robots,
    failed_robots_lines,
    replay_link,
)
from tests.report.recordings import DT, TICKS, TOUCH_TICK, make_recording, pose
from tests.report.test_report_sections import CONFIG, folder, results  # noqa: F401

TASK = "forest-7-by-hand"


def _episodes(rows):
    """``episodes.csv`` rows (env, map_seed, policy, robot, arrived, failure)."""
    return pd.DataFrame(rows, columns=["env", "map_seed", "policy", "robot", "arrived",
                                       "failure"])


@pytest.fixture
def recorded(tmp_path):
    """A folder whose records/ holds the hand-made recording as forest-7-by-hand, and the
    episodes of that task (robots 2 and 3 failed; robot 1 did not arrive per the rows but does
    not fail in the recording) and of forest-8-by-hand (not recorded)."""
    (tmp_path / "records").mkdir()
    make_recording(tmp_path / "records" / f"{TASK}.npz")
    episodes = _episodes([
        ("forest", 8, "by-hand", 0, False, "stuck"),
        ("forest", 7, "by-hand", 3, False, "collision"),
        ("forest", 7, "by-hand", 0, True, ""),
        ("forest", 7, "by-hand", 2, False, "slow"),
        ("forest", 7, "by-hand", 1, False, "detour"),
    ])
    return tmp_path, episodes


def test_time_and_place_of_each_failure_come_from_its_recording(recorded):
    out, episodes = recorded
    failed = failed_robots(episodes=episodes, records=out / "records")
    assert list(failed.columns) == list(FAILED_COLUMNS)
    assert list(zip(failed.map_seed, failed.robot, failed.cause, strict=True)) == [
        (7, 1, "detour"), (7, 2, "slow"), (7, 3, "collision"), (8, 0, "stuck")]
    rows = failed.set_index(["map_seed", "robot"])
    # robot 3 touches the trunk during tick 30 (collided from tick 31 on): it failed at 3.0 s
    collision = rows.loc[(7, 3)]
    assert collision.time_s == pytest.approx(TOUCH_TICK * DT)
    assert (collision.x_m, collision.y_m) == pytest.approx(pose(3, TOUCH_TICK)[:2])
    assert collision.replay == f"replays/{TASK}.html#robot=3&t=3.0"
    assert collision.source == f"records/{TASK}.npz"
    # robot 2 runs out of time at the end tick, 6.0 s, having driven 59 ticks of 0.05 m
    timeout = rows.loc[(7, 2)]
    assert timeout.time_s == pytest.approx(TICKS * DT)
    assert (timeout.x_m, timeout.y_m) == pytest.approx((4.0 + 0.05 * (TICKS - 1), 2.0))
    assert timeout.replay == f"replays/{TASK}.html#robot=2&t=6.0"
    # the rows say robot 1 failed, its recording does not: no time, the reason
    assert pd.isna(rows.loc[(7, 1)].time_s)
    assert rows.loc[(7, 1)].source == (f"no recording: records/{TASK}.npz does not show "
                                       "robot 1 fail")
    assert rows.loc[(7, 1)].replay == f"replays/{TASK}.html#robot=1"
    assert rows.loc[(8, 0)].source == ("no recording: records/forest-8-by-hand.npz is not in "
                                       "the folder")


def test_the_reason_of_a_missing_recording_is_the_real_one(recorded, tmp_path):
    out, episodes = recorded
    off = failed_robots(episodes=episodes, records=out / "records", record="none")
    assert set(off.source) == {'no recording: [record] episodes = "none"'}
    assert off.time_s.isna().all()
    assert set(failed_robots(episodes=episodes).source) == {
        "no recording: no folder of recordings given"}
    clone = tmp_path / "clone"
    clone.mkdir()
    _episodes(episodes.to_numpy().tolist()).to_csv(clone / "episodes.csv", index=False)
    assert set(failed_robots(clone).source) == {
        "no recording: the folder has no records/ (git keeps no recordings)"}
    (out / "records" / f"{TASK}.npz").write_bytes(b"not a zip")
    broken = failed_robots(episodes=episodes, records=out / "records")
    assert set(broken[broken.map_seed == 7].source) == {
        f"no recording: records/{TASK}.npz is not a readable recording"}


def test_a_results_folder_reads_its_record_setting_from_its_config(recorded):
    out, episodes = recorded
    episodes.to_csv(out / "episodes.csv", index=False)
    (out / "config.toml").write_text('[experiment]\nname = "x"\n\n[record]\nepisodes = "none"\n')
    assert set(failed_robots(out).source) == {'no recording: [record] episodes = "none"'}
    (out / "config.toml").write_text('[experiment]\nname = "x"\n')  # default: failures
    located = failed_robots(out)
    assert located.set_index(["map_seed", "robot"]).loc[(7, 3)].time_s == pytest.approx(3.0)


def test_the_order_follows_the_given_envs_and_policies():
    episodes = _episodes([(e, m, p, r, False, "stuck") for e in ("forest", "rocky")
                          for m in (2, 1) for p in ("b", "a") for r in (1, 0)])
    failed = failed_robots(episodes=episodes, envs=["rocky", "forest"], policies=["b", "a"])
    expected = [(e, m, p, r) for e in ("rocky", "forest") for m in (1, 2) for p in ("b", "a")
                for r in (0, 1)]
    assert list(zip(failed.env, failed.map_seed, failed.policy, failed.robot,
                    strict=True)) == expected
    with pytest.raises(ValueError, match=r"failed_robots needs results or episodes"):
        failed_robots()
    with pytest.raises(ValueError, match=r"record must be one of \['none', 'failures', 'all'\], "
                                         r"got record='some'"):
        failed_robots(episodes=episodes, record="some")


def test_the_markdown_list_is_capped_and_says_how_many_more(recorded):
    out, episodes = recorded
    failed = failed_robots(episodes=episodes, records=out / "records")
    lines = failed_robots_lines(failed, limit=2)
    assert lines[0] == "| env | map | policy | robot | cause | failed at | replay |"
    assert lines[2] == (f"| forest | 7 | by-hand | 1 | detour | no recording: records/{TASK}.npz "
                        f"does not show robot 1 fail | [replay]({replay_link(TASK, 1)}) |")
    assert lines[3] == ("| forest | 7 | by-hand | 2 | slow | 6.0 s at (6.95, 2.00) m | "
                        f"[replay](replays/{TASK}.html#robot=2&t=6.0) |")
    assert len([line for line in lines if line.startswith("| forest")]) == 2
    assert "... and 2 more robot(s): all 4 in `failures.csv`." in lines
    everything = failed_robots_lines(failed)
    assert len([line for line in everything if line.startswith("| forest")]) == 4
    assert not any("more robot" in line for line in everything)
    assert failed_robots_lines(failed.iloc[:0]) == []
    with pytest.raises(ValueError, match=r"limit must be an integer >= 1, got limit=0"):
        failed_robots_lines(failed, limit=0)


def test_an_unclassified_failure_is_a_dash_with_its_reason(recorded):
    out, episodes = recorded
    failed = failed_robots(episodes=episodes.drop(columns="failure"), records=out / "records")
    assert set(failed.cause) == {""}
    lines = failed_robots_lines(failed)
    assert lines[2].startswith("| forest | 7 | by-hand | 1 | -¹ |")
    assert lines[-2] == ("`-¹` no cause in `episodes.csv` (its `failure` column is empty or "
                         "absent).")


def test_the_report_lists_every_failed_robot_and_writes_failures_csv(results):  # noqa: F811
    shutil.copytree(results, results.parent / "copy")
    out = results.parent / "copy"
    with open(out / "episodes.csv", newline="") as fh:
        episodes = [r for r in csv.DictReader(fh) if r["arrived"] == "false"]
    # the recording made by hand stands for an episode whose robots 2 and 3 failed
    failing = {}
    for r in episodes:
        failing.setdefault(f"{r['env']}-{r['map_seed']}-{r['policy']}", set()).add(r["robot"])
    recorded_task = min(t for t, robots in failing.items() if {"2", "3"} <= robots)
    (out / "records").mkdir(exist_ok=True)
    make_recording(out / "records" / f"{recorded_task}.npz")
    report = write_report(CONFIG, out).read_text()
    with open(out / "failures.csv", newline="") as fh:
        written = list(csv.DictReader(fh))
    assert list(written[0]) == list(FAILED_COLUMNS)
    assert sorted((r["env"], r["map_seed"], r["policy"], r["robot"], r["failure"])
                  for r in episodes) == sorted(
        (r["env"], r["map_seed"], r["policy"], r["robot"], r["cause"]) for r in written)
    section = report[report.index("## Why robots failed"):report.index("## Figures")]
    for r in written:
        assert f"| {r['env']} | {r['map_seed']} | {r['policy']} | {r['robot']} | " in section
        assert f"[replay]({r['replay']})" in section
    located = [r for r in written if r["time_s"]]
    assert {(r["robot"], r["time_s"], r["source"]) for r in located} == {
        ("2", "6.000000", f"records/{recorded_task}.npz"),
        ("3", "3.000000", f"records/{recorded_task}.npz")}
    assert f"({len(written)}; all in `failures.csv`)" in section
    assert (f"`fftnav replay {out} --task {written[0]['replay'].split('/')[1].split('.')[0]} "
            f"--out {out}/replays/") in section
