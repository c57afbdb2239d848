"""The map difficulty section of report.md on a hand-made table: every undefined rho is a `-`
marked with its real reason (fewer than 3 maps, SPL the same on every map, the measure the same
on every map, both), and the section says how its Spearman p-values were computed."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from fftnav.optimal.difficulty import MEASURES
from fftnav.report.difficulty import difficulty_lines, spearman_markdown
from fftnav.report.markdown import Dashes
from fftnav.runner.maps import map_spl, spearman_table

#: Per (env, map): policy p's SPL, which falls as tortuosity grows, over 5 forest maps and 2
#: rocky ones; policy q's SPL is 0.7 on every map.
SPL_P = {("forest", m): 1.0 - 0.1 * m for m in range(1, 6)} | {("rocky", 1): 0.4,
                                                                ("rocky", 2): 0.3}


def _tables() -> tuple[pd.DataFrame, pd.DataFrame]:
    """``episodes.csv`` and ``maps.csv`` rows (one robot per map): tortuosity 1.1-1.5 on the
    forest maps and 2.1, 2.2 on the rocky ones, dispersion 3.0 on every map, the distance to
    the closest obstacle defined on forest maps 1 and 2 only; visibility and characteristic
    dimension vary."""
    episodes = pd.DataFrame([{"env": env, "map_seed": m, "policy": policy, "spl": spl}
                             for (env, m), spl_p in SPL_P.items()
                             for policy, spl in (("p", spl_p), ("q", 0.7))])
    keys = list(SPL_P)
    maps = pd.DataFrame({"env": [e for e, _ in keys], "map_seed": [m for _, m in keys],
                         "robot": 0})
    maps["distance_to_closest_obstacle_m"] = [0.5, 0.6] + [np.nan] * 5
    maps["average_visibility_m"] = [3.0, 2.0, 5.0, 1.0, 4.0, 2.5, 3.5]
    maps["dispersion"] = 3.0
    maps["characteristic_dimension_m"] = [1.0, 3.0, 2.0, 5.0, 4.0, 0.5, 6.0]
    maps["tortuosity"] = [1.0 + 0.1 * m if e == "forest" else 2.0 + 0.1 * m for e, m in keys]
    assert set(maps.columns) == {"env", "map_seed", "robot", *MEASURES}
    return episodes, maps


def _legend(line: str) -> dict[str, str]:
    """A legend line (`-¹` reason; `-²` reason.) as marks -> reasons."""
    return dict(re.findall(r"`(-[¹²³⁴⁵⁶⁷⁸⁹⁰]+)` (.*?)(?:; (?=`-)|\.$)", line))


def test_each_undefined_rho_says_why():
    episodes, maps = _tables()
    per_map = map_spl(episodes, maps)
    dashes = Dashes()
    table = spearman_markdown(spearman_table(per_map, envs=["forest", "rocky"],
                                             policies=["p", "q"]),
                              per_map=per_map, dashes=dashes)
    reasons = _legend(dashes.legend()[0])
    cell = {(r["scope"], r["policy"]): r for r in table.to_dict("records")}

    def why(scope, policy, measure):
        return reasons[cell[scope, policy][measure]]

    fewer = "fewer than 3 maps with both SPL and the measure ({}): no rank correlation"
    # 5 forest maps in the order of tortuosity: rho = -1, 1 of the 5! orderings each way
    assert cell["forest", "p"]["tortuosity"] == f"**-1.00 ({2 / 120:.2g})**"
    # pooled, 7 maps, still in order: 1 of the 7! orderings each way
    assert cell["all", "p"]["tortuosity"] == f"**-1.00 ({2 / 5040:.2g})**"
    assert why("forest", "p", "dispersion") == ("the measure is the same on every map of the "
                                                "row: no ranking")
    assert why("forest", "p", "distance_to_closest_obstacle_m") == fewer.format(2)
    assert why("all", "p", "distance_to_closest_obstacle_m") == fewer.format(2)
    assert why("rocky", "p", "tortuosity") == fewer.format(2)
    assert why("rocky", "p", "distance_to_closest_obstacle_m") == fewer.format(0)
    assert why("forest", "q", "tortuosity") == ("the policy's SPL is the same on every map of "
                                                "the row: no ranking")
    assert why("forest", "q", "dispersion") == ("the policy's SPL and the measure are both the "
                                                "same on every map of the row: no ranking")
    assert cell["forest", "q"]["predicts SPL (p < 0.05)"] == "none"
    assert len(reasons) == 5  # one number per distinct reason


def test_the_section_puts_the_reasons_and_the_p_method_under_its_table(tmp_path):
    episodes, maps = _tables()
    lines = difficulty_lines(episodes, maps, tmp_path, envs=["forest", "rocky"],
                             policies=["p", "q"])
    text = "\n".join(lines)
    assert "`-`: SPL or the measure is the same on every map" not in text
    assert not re.search(r"\| -? \|", text)  # no bare dash, no empty cell
    last_row = max(i for i, line in enumerate(lines) if line.startswith("| "))
    assert lines[last_row + 1] == "" and lines[last_row + 2].startswith("`-¹` ")
    assert "fewer than 3 maps with both SPL and the measure (2)" in lines[last_row + 2]
    # every p is over at most 9 maps: exact, in the rows of p pooled and in forest (q's SPL
    # and p's 2 rocky maps give no p)
    assert lines[last_row + 4] == ("Spearman p-values above: exact (all n! orderings of the "
                                   "maps) in the 2 row(s) of at most 9 maps (scope all, "
                                   "forest).")
    assert (tmp_path / "spl_vs_difficulty.png").read_bytes()[:4] == b"\x89PNG"
