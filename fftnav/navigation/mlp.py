"""A multilayer perceptron in numpy: the one weights format of every learned component.

A trained network, whichever library trained it, is saved as an ``.npz`` archive of plain
arrays, ``W0, b0, W1, b1, ...`` (float32 or float64), and one member ``meta``: a JSON string
holding at least ``{"kind": "controller" | "decider", "observation": NAME, "version": 1}`` plus
what the model needs (e.g. normalisation means and stds, action scaling). Running it needs
numpy alone: no torch, no jax.

Layer ``i`` maps ``h_i`` (``n_i`` values) to ``h_{i+1} = f_i(h_i W_i + b_i)`` with ``W_i`` of
shape ``(n_i, n_{i+1})`` and ``b_i`` of shape ``(n_{i+1},)``; ``f_i`` is ``activation`` for the
hidden layers and ``output`` for the last one. A ``torch.nn.Linear`` stores ``weight`` as
``(out, in)``: its ``W_i`` is ``weight.T``.

>>> import numpy as np
>>> net = MLP(weights=[np.eye(2), np.ones((2, 1))], biases=[np.zeros(2), np.array([0.5])],
...           activation="relu", meta={"kind": "controller", "observation": "x", "version": 1})
>>> net(np.array([1.0, -2.0])).tolist()
[1.5]
"""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import load_npz, parse_json, write_atomic

__all__ = ["ACTIVATIONS", "KINDS", "MLP", "OUTPUTS", "VERSION"]

#: Activations of the hidden layers.
ACTIVATIONS = ("tanh", "relu")
#: Activations of the output layer.
OUTPUTS = ("identity", "tanh")
#: What a network is for (``meta["kind"]``).
KINDS = ("controller", "decider")
#: The weights format's version (``meta["version"]``).
VERSION = 1
#: Most layers a file may hold.
MAX_LAYERS = 64

_FUNCTIONS = {
    "tanh": np.tanh,
    "relu": lambda z: np.maximum(z, 0.0),
    "identity": lambda z: z,
}


def _check_meta(meta: Any, where: str) -> dict[str, Any]:
    """``meta`` as a JSON-safe dict with the required keys, or FftnavError naming ``where``."""
    if not isinstance(meta, Mapping):
        raise FftnavError(f"{where}meta must be a dict, got meta={meta!r}")
    meta = dict(meta)
    try:
        json.dumps(meta, allow_nan=False, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise FftnavError(f"{where}meta must be JSON-serialisable (finite numbers, strings, "
                          f"lists, dicts), got meta={meta!r}: {exc}") from None
    if meta.get("kind") not in KINDS:
        raise FftnavError(f"{where}meta['kind'] must be one of {', '.join(KINDS)}, got "
                          f"kind={meta.get('kind')!r}")
    if not isinstance(meta.get("observation"), str) or not meta["observation"]:
        raise FftnavError(f"{where}meta['observation'] must be a non-empty string, got "
                          f"observation={meta.get('observation')!r}")
    if meta.get("version") != VERSION or isinstance(meta.get("version"), bool):
        raise FftnavError(f"{where}meta['version'] must be {VERSION}, got "
                          f"version={meta.get('version')!r}")
    return meta


def _check_array(value: Any, name: str, ndim: int) -> np.ndarray:
    """``value`` as a non-empty finite ``ndim``-D numeric array, or FftnavError naming it."""
    a = np.asarray(value)
    if a.ndim != ndim or a.dtype.kind not in "biuf" or 0 in a.shape:
        raise FftnavError(f"{name} must be a non-empty {ndim}-D array of numbers, got shape "
                          f"{a.shape} dtype {a.dtype}")
    if not np.all(np.isfinite(a)):
        raise FftnavError(f"{name} must be finite, got a non-finite value")
    return a


@dataclass(frozen=True)
class MLP:
    """A fully connected network: ``y = f_out(... f(f(x W0 + b0) W1 + b1) ... W_L + b_L)``.

    Parameters
    ----------
    weights : sequence of ndarray
        ``W_i`` of shape ``(n_i, n_{i+1})``, one per layer (at least one); the shapes chain
        (``W_i.shape[1] == W_{i+1}.shape[0]``). Stored as float64 arrays.
    biases : sequence of ndarray
        ``b_i`` of shape ``(n_{i+1},)``, one per layer.
    activation : {"tanh", "relu"}
        Activation of every hidden layer.
    output : {"identity", "tanh"}
        Activation of the last layer.
    meta : dict
        JSON-serialisable; at least ``kind`` (``"controller"`` or ``"decider"``),
        ``observation`` (the observation's registered name) and ``version`` (1).

    Raises
    ------
    FftnavError
        A shape that does not chain, a non-finite value, an unknown activation or a meta
        missing its keys, naming the parameter and the value.

    Examples
    --------
    >>> net = MLP(weights=[np.array([[2.0], [-1.0]])], biases=[np.array([0.5])],
    ...           meta={"kind": "decider", "observation": "features", "version": 1})
    >>> net(np.array([1.0, 3.0])).tolist(), net(np.ones((2, 2))).shape
    ([-0.5], (2, 1))
    >>> net.n_in, net.n_out, net.sizes
    (2, 1, (2, 1))
    """

    weights: tuple[np.ndarray, ...]
    biases: tuple[np.ndarray, ...]
    activation: str = field(default="tanh", kw_only=True)
    output: str = field(default="identity", kw_only=True)
    meta: dict[str, Any] = field(default_factory=dict, kw_only=True)

    def __post_init__(self) -> None:
        self._validate("")

    def _validate(self, where: str) -> None:
        if self.activation not in ACTIVATIONS:
            raise FftnavError(f"{where}activation must be one of {', '.join(ACTIVATIONS)}, got "
                              f"activation={self.activation!r}")
        if self.output not in OUTPUTS:
            raise FftnavError(f"{where}output must be one of {', '.join(OUTPUTS)}, got "
                              f"output={self.output!r}")
        weights, biases = list(self.weights), list(self.biases)
        if not weights or len(weights) > MAX_LAYERS:
            raise FftnavError(f"{where}weights must hold 1 to {MAX_LAYERS} layers, got "
                              f"{len(weights)}")
        if len(biases) != len(weights):
            raise FftnavError(f"{where}biases must hold one array per layer ({len(weights)}), "
                              f"got {len(biases)}")
        ws, bs = [], []
        for i, (w, b) in enumerate(zip(weights, biases, strict=True)):
            w = _check_array(w, f"{where}W{i}", 2)
            b = _check_array(b, f"{where}b{i}", 1)
            if i and w.shape[0] != ws[-1].shape[1]:
                raise FftnavError(f"{where}W{i} must have {ws[-1].shape[1]} rows (the columns "
                                  f"of W{i - 1}), got shape {w.shape}")
            if b.shape != (w.shape[1],):
                raise FftnavError(f"{where}b{i} must have shape ({w.shape[1]},) (the columns "
                                  f"of W{i}), got shape {b.shape}")
            ws.append(np.array(w, dtype=np.float64))
            bs.append(np.array(b, dtype=np.float64))
        for a in ws + bs:
            a.setflags(write=False)
        object.__setattr__(self, "weights", tuple(ws))
        object.__setattr__(self, "biases", tuple(bs))
        object.__setattr__(self, "meta", _check_meta(self.meta, where))

    @property
    def n_in(self) -> int:
        """Length of an input vector."""
        return int(self.weights[0].shape[0])

    @property
    def n_out(self) -> int:
        """Length of an output vector."""
        return int(self.weights[-1].shape[1])

    @property
    def sizes(self) -> tuple[int, ...]:
        """Widths of the layers, input first: ``(n_0, n_1, ..., n_out)``."""
        return (self.n_in, *(int(w.shape[1]) for w in self.weights))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The network's output for one input ``(n_in,)`` or a batch ``(B, n_in)``.

        Parameters
        ----------
        x : array_like, shape (n_in,) or (B, n_in)
            Input(s), converted to float64.

        Returns
        -------
        ndarray, float64, shape (n_out,) or (B, n_out)
        """
        h = np.asarray(x, dtype=np.float64)
        if h.ndim not in (1, 2) or h.shape[-1] != self.n_in:
            raise FftnavError(f"x must have shape ({self.n_in},) or (B, {self.n_in}), got "
                              f"shape {h.shape}")
        hidden = _FUNCTIONS[self.activation]
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = h @ w + b
            h = _FUNCTIONS[self.output](h) if i == last else hidden(h)
        return h

    def save(self, path: str | Path) -> Path:
        """Write the network to ``path`` (``.npz``): ``W0, b0, ...`` as float64 and ``meta``,
        the JSON of ``meta`` with ``activation`` and ``output`` added. Written atomically;
        the same network writes the same bytes.

        Returns
        -------
        Path
            The file written.
        """
        path = Path(path)
        meta = {**self.meta, "activation": self.activation, "output": self.output}
        members: dict[str, np.ndarray] = {}
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            members[f"W{i}"], members[f"b{i}"] = w, b
        members["meta"] = np.array(json.dumps(meta, sort_keys=True, allow_nan=False))
        # A zip member's timestamp is fixed so that the bytes depend on the network alone.
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            for name, array in members.items():
                info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                data = io.BytesIO()
                np.lib.format.write_array(data, np.asarray(array),
                                          allow_pickle=False)
                archive.writestr(info, data.getvalue())
        write_atomic(path, buffer.getvalue())
        return path

    @classmethod
    def load(cls, path: str | Path) -> MLP:
        """Read a network written by :meth:`save` (or by any library, in the same format).

        Raises
        ------
        FftnavError
            A missing or damaged file, a missing ``W_i``/``b_i``/``meta``, shapes that do not
            chain, a non-finite value or a bad meta, naming the file.
        """
        try:
            arrays = load_npz(path)
        except FileNotFoundError:
            raise FftnavError(f"{path}: no such file") from None
        where = f"{path}: "
        if "meta" not in arrays:
            raise FftnavError(f"{where}has no 'meta' member (a JSON string)")
        text = arrays.pop("meta")
        if text.size != 1 or text.dtype.kind != "U":
            raise FftnavError(f"{where}meta must be a JSON string, got shape {text.shape} "
                              f"dtype {text.dtype}")
        text = str(text.reshape(()))
        meta = parse_json(text, where=f"{path}[meta]")
        if not isinstance(meta, dict):
            raise FftnavError(f"{where}meta must be a JSON object, got {text[:80]!r}")
        activation = meta.pop("activation", "tanh")
        output = meta.pop("output", "identity")
        n = sum(1 for name in arrays if name.startswith("W"))
        expected = {f"{p}{i}" for i in range(n) for p in "Wb"}
        if set(arrays) != expected:
            extra = sorted(set(arrays) - expected)
            missing = sorted(expected - set(arrays))
            raise FftnavError(f"{where}members must be W0, b0, ..., W{n - 1}, b{n - 1} and meta, "
                              f"got missing {missing} and unexpected {extra}")
        net = object.__new__(cls)
        for name, value in (("weights", tuple(arrays[f"W{i}"] for i in range(n))),
                            ("biases", tuple(arrays[f"b{i}"] for i in range(n))),
                            ("activation", activation), ("output", output), ("meta", meta)):
            object.__setattr__(net, name, value)
        net._validate(where)
        return net

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MLP):
            return NotImplemented
        arrays = (*self.weights, *self.biases)
        others = (*other.weights, *other.biases)
        return (self.activation == other.activation and self.output == other.output
                and self.meta == other.meta and len(arrays) == len(others)
                and all(np.array_equal(a, b) for a, b in zip(arrays, others, strict=True)))

    __hash__ = None  # type: ignore[assignment]

