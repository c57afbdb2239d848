"""The features of one Bug decision (observation ``decision-v1``): a fixed-length float vector.

From what the paper's Bayesian fusion uses at a decision
(:class:`~fftnav.navigation.policies.DecisionObservation`), all in the robot's goal frame (x
towards the goal, y to its left; angles in radians, CCW):

=========================  =====================================================================
elements                   value
=========================  =====================================================================
``0``                      P_s, the robot's own probability of turning left (eq. (P_s))
``1 + 5k .. 5 + 5k``       neighbour slot ``k`` (``k`` = 0 .. 3, the K = 4 nearest senders of
                           the inbox, nearest first; ties keep the inbox's sender order):
                           present (1, or 0 for an empty slot), its P_i (eq. (P_ni)), its
                           distance / comm range (at most 2: a sender placed with pose noise
                           may seem beyond the range), cos and sin of its bearing
                           (``atan2(y, x)``); an empty slot is all zeros
``21 + 4e .. 24 + 4e``     extremum slot ``e`` (``e`` = 0 .. 7, the E = 8 extrema of the own
                           scan nearest the goal direction in angle, i.e. smallest
                           ``|angle|``, ties to the lower angle; listed by increasing angle):
                           present (1 or 0), distance / R, cos and sin of its angle; an empty
                           slot is all zeros
=========================  =====================================================================

53 values in all (:data:`N_FEATURES`); each lies in ``[-1, 1]`` but the distances to
neighbours, which lie in ``[0, 2]``. Pure numpy.

>>> import numpy as np
>>> from fftnav.navigation.policies import DecisionObservation
>>> obs = DecisionObservation(0.7, np.array([[0.5, 2.0]]), np.array([0.4]),
...                           np.array([[0.0, 3.0, 0.0]]), range_m=4.0, comm_range_m=6.0)
>>> f = decision_features(obs)
>>> f.shape, float(f[0])
((53,), 0.7)
>>> [round(float(v), 3) for v in f[1:6]]
[1.0, 0.4, 0.5, 0.0, 1.0]
"""

from __future__ import annotations

import numpy as np

from fftnav.errors import FftnavError
from fftnav.navigation.policies import DecisionObservation

__all__ = ["EXTREMA", "NAME", "NEIGHBOURS", "N_FEATURES", "decision_features", "feature_names"]

#: The observation's name (``meta["observation"]`` of a decider's weights).
NAME = "decision-v1"
#: Neighbour slots (K) and values per slot.
NEIGHBOURS, _PER_NEIGHBOUR = 4, 5
#: Extremum slots (E) and values per slot.
EXTREMA, _PER_EXTREMUM = 8, 4
#: Length of the feature vector.
N_FEATURES = 1 + NEIGHBOURS * _PER_NEIGHBOUR + EXTREMA * _PER_EXTREMUM


def feature_names() -> list[str]:
    """The name of every element, in order (``p_s``, ``n0_present``, ..., ``e7_sin``).

    >>> names = feature_names()
    >>> len(names), names[:3], names[21:23]
    (53, ['p_s', 'n0_present', 'n0_p'], ['e0_present', 'e0_dist'])
    """
    names = ["p_s"]
    for k in range(NEIGHBOURS):
        names += [f"n{k}_{v}" for v in ("present", "p", "dist", "cos", "sin")]
    for e in range(EXTREMA):
        names += [f"e{e}_{v}" for v in ("present", "dist", "cos", "sin")]
    return names


def _neighbour_slots(obs: DecisionObservation) -> np.ndarray:
    rel = np.asarray(obs.rel_poses, dtype=np.float64).reshape(-1, 3)
    p = np.asarray(obs.p_neighbours, dtype=np.float64).reshape(-1)
    if len(p) != len(rel):
        raise FftnavError(f"p_neighbours must have one value per row of rel_poses "
                          f"({len(rel)}), got p_neighbours={p.tolist()}")
    dist = np.hypot(rel[:, 0], rel[:, 1])
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    out = np.zeros((NEIGHBOURS, _PER_NEIGHBOUR))
    for slot, j in enumerate(np.argsort(dist, kind="stable")[:NEIGHBOURS]):
        out[slot] = (1.0, p[j], min(dist[j] / obs.comm_range_m, 2.0), np.cos(bearing[j]),
                     np.sin(bearing[j]))
    return out.reshape(-1)


def _extremum_slots(obs: DecisionObservation) -> np.ndarray:
    sigma = np.asarray(obs.sigma, dtype=np.float64).reshape(-1, 2)
    angle, dist = sigma[:, 0], sigma[:, 1]
    # nearest the goal direction first, ties to the lower angle; then by increasing angle
    nearest = np.lexsort((angle, np.abs(angle)))[:EXTREMA]
    chosen = nearest[np.argsort(angle[nearest], kind="stable")]
    out = np.zeros((EXTREMA, _PER_EXTREMUM))
    for slot, j in enumerate(chosen):
        out[slot] = (1.0, dist[j] / obs.range_m, np.cos(angle[j]), np.sin(angle[j]))
    return out.reshape(-1)


def decision_features(obs: DecisionObservation) -> np.ndarray:
    """The ``decision-v1`` vector of one decision (module docstring: element by element).

    Parameters
    ----------
    obs : DecisionObservation
        P_s, the own extrema and the received messages' P_i and poses, in the goal frame
        (:meth:`DecisionContext.observation
        <fftnav.navigation.policies.DecisionContext>`).

    Returns
    -------
    ndarray, (53,) float64
    """
    if not isinstance(obs, DecisionObservation):
        raise FftnavError(f"obs must be a DecisionObservation, got obs={obs!r:.80}")
    return np.concatenate([[float(obs.p_s)], _neighbour_slots(obs), _extremum_slots(obs)])
