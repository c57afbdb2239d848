"""Navigation metrics: pure functions of trajectories and per-robot tables (no simulator).

One module per concern, every public name of each importable from ``fftnav.metrics``:

- :mod:`fftnav.metrics.paths`: a robot's path measures (Anderson et al. 2018, as used by the
  paper): :func:`path_length_m`, :func:`time_to_goal_s`, :func:`arrived`, the SPL terms and AR,
  APL and SPL over robots; :func:`motions` (driving, correcting, turning, standing).
- :mod:`fftnav.metrics.measures`: the measures registry, :data:`MEASURES` (one summary column
  per measure, habitat-lab style), :func:`register_measure`, :func:`evaluate`, and the
  neighbour accounting's reasons, :data:`NEIGHBOUR_REASONS`.
- :mod:`fftnav.metrics.failures`: why a robot did not arrive: :class:`FailureThresholds`,
  :func:`failure_features`, :func:`classify_failure` and the causes in their declared order,
  :data:`FAILURE_CAUSES` (:func:`register_failure_cause`), each with a ``failures_<cause>``
  measure.

Distances in metres, times in seconds; ``docs/metrics.md`` states every definition. numpy,
:mod:`fftnav.validate` and :mod:`fftnav.registry` only.
"""

from __future__ import annotations

from fftnav.metrics.failures import (
    FAILURE_CAUSES,
    FailureCause,
    FailureCauses,
    FailureFeatures,
    FailureThresholds,
    classify_failure,
    failure_features,
    register_failure_cause,
)
from fftnav.metrics.measures import (
    MEASURES,
    NEIGHBOUR_REASONS,
    Measure,
    Table,
    evaluate,
    register_measure,
)
from fftnav.metrics.paths import (
    MOTIONS,
    arrival_rate,
    arrived,
    average_path_length_m,
    motions,
    path_length_m,
    spl,
    spl_terms,
    time_to_goal_s,
)

__all__ = [
    "FAILURE_CAUSES",
    "FailureCause",
    "FailureCauses",
    "FailureFeatures",
    "FailureThresholds",
    "MEASURES",
    "MOTIONS",
    "Measure",
    "NEIGHBOUR_REASONS",
    "Table",
    "arrival_rate",
    "arrived",
    "average_path_length_m",
    "classify_failure",
    "evaluate",
    "failure_features",
    "motions",
    "path_length_m",
    "register_failure_cause",
    "register_measure",
    "spl",
    "spl_terms",
    "time_to_goal_s",
]
