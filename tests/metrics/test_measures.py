"""fftnav.metrics.measures: the measures registry, by name, on per-robot tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from fftnav.metrics import MEASURES, evaluate
from tests.metrics.tables import episode_table


@pytest.mark.parametrize("as_frame", [False, True])
def test_measures_registry_by_name(as_frame):
    table = episode_table()
    if as_frame:
        table = pd.DataFrame(table)
    got = evaluate(table)
    assert set(got) == set(MEASURES)
    assert got["ar"] == pytest.approx(2 / 3)
    assert got["apl_m"] == pytest.approx(19.5)
    assert got["spl"] == pytest.approx((19 / 20 + 1) / 3)
    assert got["spl_geodesic"] == pytest.approx((18 / 20 + 18 / 19) / 3)
    assert got["collision_rate"] == pytest.approx(1 / 3)
    assert got["time_to_goal_s"] == pytest.approx(60.0)
    assert got["bytes_per_robot"] == pytest.approx(100.0)
    assert got["messages_per_robot"] == pytest.approx(4.0)
    assert got["decisions_per_robot"] == pytest.approx(2.0)
    assert got["share_with_neighbours"] == pytest.approx(2 / 6)
    assert got["share_flipped_by_neighbours"] == pytest.approx(1 / 2)
    assert got["robot_contacts_per_robot"] == pytest.approx(1.0)
    assert got["share_neighbours_fused"] == pytest.approx(3 / 12)  # 12 neighbours counted
    assert got["share_neighbours_no_message"] == pytest.approx(4 / 12)
    assert got["share_neighbours_behind"] == 0.0
    old = {k: v for k, v in episode_table().items() if not k.startswith("neighbours_")}
    assert np.isnan(evaluate(old, ["share_neighbours_lost"])["share_neighbours_lost"])
    assert MEASURES["spl"](table) == got["spl"]
    for name in ("ar", "apl_m", "spl"):  # the interval terms are the measure as a ratio
        num, den = MEASURES[name].terms(table)
        assert num.sum() / den.sum() == pytest.approx(got[name])
    assert MEASURES["apl_m"].columns == ("apl_m", "apl_ci_low", "apl_ci_high")
    assert MEASURES["spl_geodesic"].columns == ("spl_geodesic",)


def test_a_registered_measure_becomes_a_summary_column(monkeypatch):
    from fftnav.metrics import measures, register_measure
    from fftnav.runner.summary import summarize, summary_columns

    monkeypatch.setattr(measures, "MEASURES", MEASURES.copy())
    monkeypatch.setattr("fftnav.runner.summary.MEASURES", measures.MEASURES)
    register_measure("longest_path_m")(lambda t: float(np.max(t["path_length_m"])))
    assert summary_columns()[-1] == "longest_path_m"
    frame = pd.DataFrame({**episode_table(), "env": "forest", "policy": "fusion", "map_seed": 1})
    assert summarize(frame, n_resamples=10)["longest_path_m"].tolist() == [20.0]
    with pytest.raises(ValueError, match="measure 'spl' is already registered"):
        register_measure("spl")(lambda t: 0.0)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: evaluate(episode_table(), ["nope"]),
         r"names must be a registered measure \('ar', .*got names='nope'"),
        (lambda: MEASURES["spl"]({"arrived": [True]}), r"table must have a column 'path_length_m'"),
    ],
)
def test_invalid_inputs_raise(call, message):
    with pytest.raises(ValueError, match=message):
        call()
