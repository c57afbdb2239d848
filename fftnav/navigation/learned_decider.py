"""The learned decider: a network picks the Bug planner's side from the ``decision-v1`` features.

At each decision the planner asks for a side (paper Sec. III-E); the learned decider feeds the
decision's features (:func:`fftnav.navigation.decision_features.decision_features`: its own
P_s, the neighbours' received P_i and relative positions, the extrema of its scan) to an
:class:`~fftnav.navigation.mlp.MLP` with one output, a logit, and passes on the left iff the
logit is > 0. Its robots broadcast their compressed observation as ``fusion``'s do, so that the
neighbours' P_i are there to read. It runs in numpy alone.

The network's ``meta`` must say ``"kind": "decider"`` and ``"observation": "decision-v1"``; it
may hold ``"mean"`` and ``"std"`` (53 numbers each, std > 0): the features are then fed as
``(x - mean) / std``.

>>> net = untrained_decider(0)
>>> net.sizes, net.meta["observation"]
((53, 64, 64, 1), 'decision-v1')
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fftnav.errors import FftnavError
from fftnav.navigation.decision_features import N_FEATURES, NAME, decision_features
from fftnav.navigation.mlp import MLP, VERSION
from fftnav.navigation.policies import LEFT, RIGHT, DecisionContext, Policy
from fftnav.validate import check_integer

__all__ = ["PREFIX", "check_decider", "decider_logit", "learned_decider_policy",
           "untrained_decider"]

#: The prefix naming a learned decider: ``learned-decider:PATH.npz``.
PREFIX = "learned-decider:"


def check_decider(net: MLP, *, where: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Check that ``net`` is a decider on ``decision-v1`` (53 inputs, one output); its
    normalisation ``(mean, std)`` (zeros and ones without ``meta["mean"]``/``meta["std"]``).

    Raises
    ------
    FftnavError
        Another kind, observation, input or output size, or a bad mean or std, naming
        ``where`` (the file) and the value.
    """
    meta = net.meta
    if meta.get("kind") != "decider":
        raise FftnavError(f"{where}meta['kind'] must be 'decider', got kind={meta.get('kind')!r}")
    if meta.get("observation") != NAME:
        raise FftnavError(f"{where}meta['observation'] must be {NAME!r}, got "
                          f"observation={meta.get('observation')!r}")
    if net.n_in != N_FEATURES or net.n_out != 1:
        raise FftnavError(f"{where}the network must map {N_FEATURES} inputs to 1 output (a "
                          f"logit), got sizes={net.sizes}")
    mean = np.asarray(meta.get("mean", [0.0] * N_FEATURES), dtype=np.float64)
    std = np.asarray(meta.get("std", [1.0] * N_FEATURES), dtype=np.float64)
    for name, value in (("mean", mean), ("std", std)):
        if value.shape != (N_FEATURES,) or not np.isfinite(value).all():
            raise FftnavError(f"{where}meta['{name}'] must be {N_FEATURES} finite numbers, got "
                              f"{name}={value.tolist()!r:.120}")
    if (std <= 0).any():
        raise FftnavError(f"{where}meta['std'] must be > 0 everywhere, got "
                          f"std={std.tolist()!r:.120}")
    return mean, std


def decider_logit(net: MLP, features: np.ndarray) -> float:
    """The network's logit for one ``decision-v1`` vector (normalised by its meta)."""
    mean, std = check_decider(net)
    return float(net((np.asarray(features, dtype=np.float64) - mean) / std)[0])


def learned_decider_policy(path: str | Path) -> Policy:
    """The decision policy of the decider saved at ``path`` (``learned-decider:PATH`` resolves
    to it): LEFT iff the logit > 0, else RIGHT.

    Parameters
    ----------
    path : str or Path
        An ``.npz`` written by :meth:`MLP.save <fftnav.navigation.mlp.MLP.save>`.

    Returns
    -------
    Policy
        Named ``learned-decider-<stem of the file>`` (the name its rows carry); its robots
        broadcast their compressed observation (messages ``"observation"``).

    Raises
    ------
    FftnavError
        An unreadable file, or a network that is not a ``decision-v1`` decider, naming the file.
    """
    net = MLP.load(path)
    mean, std = check_decider(net, where=f"{path}: ")

    def decide(ctx: DecisionContext) -> int:
        obs = ctx.observation()
        if obs is None:
            raise FftnavError(f"{PREFIX}{path} needs the Bug planner's decision observation, "
                              f"got observation=None")
        logit = float(net((decision_features(obs) - mean) / std)[0])
        return LEFT if logit > 0.0 else RIGHT

    return Policy(f"learned-decider-{Path(path).stem}", decide, "observation",
                  f"a learned decider ({Path(path).name}): left iff its logit > 0")


def untrained_decider(seed: int, *, hidden: Sequence[int] = (64, 64),
                      activation: str = "tanh") -> MLP:
    """A decider network with random weights (the baseline a trained one is compared with).

    Parameters
    ----------
    seed : int
        Seed of its generator (same seed, same weights).
    hidden : sequence of int
        Widths of the hidden layers.
    activation : {"tanh", "relu"}

    Returns
    -------
    MLP
        ``53 -> hidden -> 1``; each ``W_i`` drawn from N(0, 1 / n_i) (``n_i`` its inputs),
        biases 0; meta ``{"kind": "decider", "observation": "decision-v1", "version": 1}``.
    """
    seed = check_integer("seed", seed, low=0)
    sizes = [N_FEATURES, *(check_integer("hidden", h, low=1) for h in hidden), 1]
    rng = np.random.default_rng(seed)
    weights = [rng.normal(0.0, 1.0 / np.sqrt(a), (a, b))
               for a, b in zip(sizes[:-1], sizes[1:], strict=True)]
    biases = [np.zeros(b) for b in sizes[1:]]
    return MLP(weights=weights, biases=biases, activation=activation, output="identity",
               meta={"kind": "decider", "observation": NAME, "version": VERSION})
