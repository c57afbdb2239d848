"""fftnav.suites.leaderboard: the table of every method on every suite, and submissions
checked before they are added."""

from __future__ import annotations

import json

import pandas as pd
import pytest

import fftnav
from fftnav.suites.evaluate import Options, evaluate
from fftnav.suites.leaderboard import (
    add_submission,
    build_leaderboard,
    leaderboard_episodes,
    rows_sha256,
)

QUIET = Options(workers=1, progress=False)


@pytest.fixture
def evaluated(tiny, tmp_path):
    """An fftnav evaluate folder of own-only on the tiny suite."""
    out = tmp_path / "eval"
    evaluate("own-only", ["tiny"], out, options=QUIET)
    return out


def test_the_leaderboard_ranks_every_reference_method(tiny):
    table = build_leaderboard(suites=["tiny"])
    assert sorted(table["method"]) == ["bug-left", "bug-right", "fusion"]
    assert table["rank"].min() == 1 and (table["suite"] == "tiny-v1").all()


def test_a_submission_is_checked_added_and_ranked(evaluated, tmp_path):
    board = tmp_path / "board"
    assert add_submission(evaluated, board) == "own-only"
    kept = board / "submissions" / "own-only"
    assert sorted(p.name for p in kept.iterdir()) == ["evaluation.json", "tiny-v1.csv",
                                                      "tiny-v1.timing.csv"]
    table = build_leaderboard(board, suites=["tiny"])
    assert "own-only" in set(table["method"])
    assert table.set_index("method").loc["own-only", "compute_ms"] > 0
    rows, _ = leaderboard_episodes(board, suites=["tiny"])["tiny-v1"]
    mine = pd.read_csv(evaluated / "runs" / "tiny-v1" / "episodes.csv")
    assert rows_sha256(rows[rows["policy"] == "own-only"]) == rows_sha256(mine)


def test_rows_changed_after_the_evaluation_are_refused(evaluated, tmp_path):
    path = evaluated / "runs" / "tiny-v1" / "episodes.csv"
    table = pd.read_csv(path)
    table.loc[0, "spl"] = 1.0 - table.loc[0, "spl"] / 2
    table.to_csv(path, index=False)
    with pytest.raises(ValueError, match=r"the rows of own-only on tiny-v1 are not those the "
                       r"evaluation recorded \(changed after it ran\)"):
        add_submission(evaluated, tmp_path / "board")
    assert not (tmp_path / "board" / "submissions").exists()


@pytest.mark.parametrize(("key", "value", "message"), [
    ("fftnav_version", "0.0.1", r"was written by fftnav 0.0.1, this is fftnav "),
    ("method_sha256", "", r"has no method_sha256"),
])
def test_an_evaluation_of_another_version_is_refused(evaluated, tmp_path, key, value,
                                                      message):
    record = evaluated / "evaluation.json"
    info = json.loads(record.read_text())
    info[key] = value
    record.write_text(json.dumps(info))
    with pytest.raises(ValueError, match=message):
        add_submission(evaluated, tmp_path / "board")


def test_other_pins_and_unknown_suites_are_refused(evaluated, tmp_path):
    record = evaluated / "evaluation.json"
    info = json.loads(record.read_text())
    info["suites"]["tiny-v1"]["pins_sha256"] = "0" * 64
    record.write_text(json.dumps(info))
    with pytest.raises(ValueError, match=r"suite tiny-v1 was evaluated with other pins"):
        add_submission(evaluated, tmp_path / "board")
    info["suites"]["tiny-v9"] = info["suites"].pop("tiny-v1")
    record.write_text(json.dumps(info))
    with pytest.raises(ValueError, match=r"suite 'tiny-v9' is not one of this fftnav's suites"):
        add_submission(evaluated, tmp_path / "board")


def test_a_folder_that_is_not_an_evaluation_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"evaluation_dir must be a folder written by fftnav "
                       r"evaluate \(with evaluation.json\), got evaluation_dir="):
        add_submission(tmp_path, tmp_path / "board")
    (tmp_path / "evaluation.json").write_text("{")
    with pytest.raises(ValueError, match=r"evaluation.json is damaged"):
        add_submission(tmp_path, tmp_path / "board")
    assert fftnav.__version__
