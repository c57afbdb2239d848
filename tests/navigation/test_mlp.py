"""The numpy MLP and its ``.npz`` weights format: forward pass against hand-worked values and
(if installed) torch, save/load round trip, and every refusal naming the parameter or file."""

from __future__ import annotations

import json
import math
import zipfile

import numpy as np
import pytest

from fftnav.errors import FftnavError
from fftnav.navigation.mlp import MLP

META = {"kind": "controller", "observation": "ranges", "version": 1}


def _net(**kw):
    base = dict(weights=[np.array([[1.0, -1.0], [2.0, 0.5]]), np.array([[1.0], [-2.0]])],
                biases=[np.array([0.0, 1.0]), np.array([0.25])], meta=META)
    return MLP(**{**base, **kw})


def test_forward_pass_of_a_hand_worked_tiny_network():
    # x = (1, 2): hidden pre-activation (1*1 + 2*2 + 0, 1*-1 + 2*0.5 + 1) = (5, 1)
    x = np.array([1.0, 2.0])
    relu = _net(activation="relu")(x)
    assert relu.tolist() == [5.0 - 2.0 + 0.25]
    tanh = _net(activation="tanh", output="tanh")(x)
    assert tanh[0] == pytest.approx(math.tanh(math.tanh(5) - 2 * math.tanh(1) + 0.25), abs=1e-15)
    # a batch gives the rows one by one
    batch = np.array([[1.0, 2.0], [-3.0, 0.5], [0.0, 0.0]])
    net = _net(activation="relu")
    assert net(batch).shape == (3, 1)
    assert net(batch)[:, 0].tolist() == [net(row)[0] for row in batch]
    assert net(batch[1])[0] == pytest.approx(0.0 - 2 * max(3 + 0.25 + 1, 0) + 0.25)


def test_forward_pass_matches_torch_sequential():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(3)
    sizes = [7, 16, 9, 2]
    ws = [rng.normal(size=(a, b)) for a, b in zip(sizes[:-1], sizes[1:], strict=True)]
    bs = [rng.normal(size=b) for b in sizes[1:]]
    net = MLP(weights=ws, biases=bs, activation="tanh", output="tanh", meta=META)
    layers = []
    for i, (w, b) in enumerate(zip(ws, bs, strict=True)):
        lin = torch.nn.Linear(*w.shape)
        with torch.no_grad():
            lin.weight.copy_(torch.tensor(w.T))
            lin.bias.copy_(torch.tensor(b))
        layers += [lin, torch.nn.Tanh()] if i < len(ws) - 1 else [lin, torch.nn.Tanh()]
    seq = torch.nn.Sequential(*layers)
    x = rng.normal(size=(5, 7))
    with torch.no_grad():
        expected = seq(torch.tensor(x, dtype=torch.float32)).numpy()
    assert np.abs(net(x) - expected).max() < 1e-5


def test_save_load_round_trip_and_same_bytes(tmp_path):
    net = _net(activation="relu", output="tanh",
               meta={**META, "obs_mean": [0.5, 1.0], "note": "x"})
    a, b = net.save(tmp_path / "a.npz"), net.save(tmp_path / "b.npz")
    assert a.read_bytes() == b.read_bytes()
    back = MLP.load(a)
    assert back == net and back.activation == "relu" and back.output == "tanh"
    assert back.meta == {**META, "obs_mean": [0.5, 1.0], "note": "x"}
    x = np.array([0.3, -0.7])
    assert back(x).tolist() == net(x).tolist()
    # the members are plain arrays and a JSON string, readable without fftnav
    with np.load(a, allow_pickle=False) as z:
        assert sorted(z.files) == ["W0", "W1", "b0", "b1", "meta"]
        assert json.loads(str(z["meta"]))["activation"] == "relu"


def test_float32_weights_written_by_another_library_load(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, W0=np.ones((3, 2), np.float32), b0=np.zeros(2, np.float32),
             meta=json.dumps({"kind": "decider", "observation": "features", "version": 1}))
    net = MLP.load(path)
    assert net.weights[0].dtype == np.float64 and net(np.ones(3)).tolist() == [3.0, 3.0]
    assert net.activation == "tanh" and net.output == "identity"


@pytest.mark.parametrize(("kw", "match"), [
    ({"activation": "sigmoid"}, r"activation must be one of tanh, relu, got activation='sigmoid'"),
    ({"output": "softmax"}, r"output must be one of identity, tanh, got output='softmax'"),
    ({"weights": []}, r"weights must hold 1 to 64 layers, got 0"),
    ({"biases": [np.zeros(2)]}, r"biases must hold one array per layer \(2\), got 1"),
    ({"weights": [np.ones((2, 2)), np.ones((3, 1))]},
     r"W1 must have 2 rows \(the columns of W0\), got shape \(3, 1\)"),
    ({"biases": [np.zeros(3), np.zeros(1)]},
     r"b0 must have shape \(2,\) \(the columns of W0\), got shape \(3,\)"),
    ({"weights": [np.ones(2), np.ones((2, 1))]}, r"W0 must be a non-empty 2-D array of numbers"),
    ({"weights": [np.array([[1.0, np.nan], [0, 0]]), np.ones((2, 1))]},
     r"W0 must be finite, got a non-finite value"),
    ({"meta": {"kind": "robot", "observation": "x", "version": 1}},
     r"meta\['kind'\] must be one of controller, decider, got kind='robot'"),
    ({"meta": {"kind": "controller", "version": 1}},
     r"meta\['observation'\] must be a non-empty string, got observation=None"),
    ({"meta": {**META, "version": 2}}, r"meta\['version'\] must be 1, got version=2"),
    ({"meta": {**META, "x": float("nan")}}, r"meta must be JSON-serialisable"),
    ({"meta": [1]}, r"meta must be a dict, got meta=\[1\]"),
])
def test_bad_networks_are_refused_naming_the_parameter(kw, match):
    with pytest.raises(FftnavError, match=match):
        _net(**kw)


def test_bad_input_shape_is_refused():
    with pytest.raises(FftnavError, match=r"x must have shape \(2,\) or \(B, 2\), got shape \(3,\)"):
        _net()(np.ones(3))


def _write(path, members):
    with zipfile.ZipFile(path, "w") as z:
        for name, value in members.items():
            with z.open(f"{name}.npy", "w") as fh:
                np.lib.format.write_array(fh, np.asarray(value))


@pytest.mark.parametrize(("members", "match"), [
    ({"W0": np.ones((2, 1)), "b0": np.ones(1)}, r"has no 'meta' member"),
    ({"W0": np.ones((2, 1)), "b0": np.ones(1), "meta": "{bad"}, r"\[meta\]: not valid JSON"),
    ({"W0": np.ones((2, 1)), "b0": np.ones(1), "meta": "[1]"}, r"meta must be a JSON object"),
    ({"W0": np.ones((2, 1)), "b0": np.ones(1), "meta": np.ones(2)},
     r"meta must be a JSON string"),
    ({"W0": np.ones((2, 1)), "meta": json.dumps(META)},
     r"members must be W0, b0, \.\.\., W0, b0 and meta, got missing \['b0'\]"),
    ({"W0": np.ones((2, 1)), "b0": np.ones(1), "W1": np.ones((2, 2)), "b1": np.ones(2),
      "meta": json.dumps(META)}, r"W1 must have 1 rows \(the columns of W0\)"),
    ({"W0": np.ones((2, 1)), "b0": np.ones(1), "meta": json.dumps({**META, "kind": "x"})},
     r"meta\['kind'\] must be one of controller, decider"),
    ({"W0": np.ones((2, 1)), "b0": np.full(1, np.inf), "meta": json.dumps(META)},
     r"b0 must be finite"),
])
def test_bad_files_are_refused_naming_the_file(tmp_path, members, match):
    path = tmp_path / "net.npz"
    _write(path, members)
    with pytest.raises(FftnavError, match=match) as err:
        MLP.load(path)
    assert str(path) in str(err.value)


def test_missing_and_damaged_files_are_refused_naming_them(tmp_path):
    with pytest.raises(FftnavError, match="nope.npz"):
        MLP.load(tmp_path / "nope.npz")
    (tmp_path / "junk.npz").write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(FftnavError, match="junk.npz"):
        MLP.load(tmp_path / "junk.npz")
