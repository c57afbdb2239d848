"""The HTML player's data (fftnav.report.replay_html): the arrays the page reads, decoded here as
the page does, against the recording made by hand."""

from __future__ import annotations

import base64
import json
import re
import zlib

import numpy as np
import pytest

from fftnav.episode.recording import read_recording
from fftnav.report.frames import ESTIMATE_LABEL, KINDS, TRUTH_LABEL
from fftnav.report.replay_html import player_data, write_html
from tests.report.recordings import MODES, TICKS, estimate, expected_kind, make_recording, pose

TYPES = {"Float32Array": "<f4", "Uint8Array": "u1", "Uint16Array": "<u2", "Int32Array": "<i4"}


def _arrays(header, data):
    buffer = zlib.decompress(data)
    return {name: np.frombuffer(buffer, TYPES[kind], length, offset)
            for name, (offset, kind, length) in header["arrays"].items()}


def test_window_arrays_are_the_recordings(recording):
    header, data = player_data(recording, robot=2, from_s=1.0, to_s=3.0, speed=2)
    g = header["ticks"]
    assert g == 21 and header["robots"] == 4 and header["picked"] == 2 and header["speed"] == 2
    a = _arrays(header, data)
    np.testing.assert_allclose(a["time"], np.arange(10, 31) * 0.1, atol=1e-5)
    pose_ = a["pose"].reshape(g, 4, 3)
    for k, tick in enumerate(range(10, 31)):
        np.testing.assert_allclose(pose_[k], [pose(i, tick) for i in range(4)], atol=1e-5)
    kinds = a["kind"].reshape(g, 4)
    assert [header["kinds"][c] for c in kinds[0]] == [expected_kind(i, 10) for i in range(4)]
    assert header["kinds"] == list(KINDS)
    assert [header["kinds"][c] for c in header["driving"]] == [
        "moving", "following", "escaping", "guided"]
    assert (np.diff(a["msgStart"]) == 1).all() and a["msg"].reshape(-1, 2).tolist() == [[0, 1]] * g
    m = len(header["angles"])
    scan = a["scan"].reshape(g, 4, m) * header["scanStep"]
    ahead = np.abs(recording.angles_rad) < np.pi / 2  # the header rounds them to 1e-6
    np.testing.assert_allclose(scan[5, 1, ahead], 1.0)
    safe = np.unpackbits(a["safe"].reshape(g, 4, -1), axis=-1, count=m).astype(bool)
    assert (safe[5, 1] == ~ahead).all() and not safe[5, 0].any()
    names = header["stateNames"]
    state = a["state"].reshape(len(names), g, 4)
    assert names[:3] == ["mode", "side", "decisions"]
    assert state[names.index("mode"), 0].tolist() == [float(m) for m in MODES]
    assert state[names.index("command v (m/s)"), 0, 0] == pytest.approx(0.5)
    assert [o["failure"] for o in header["outcomes"]] == ["", "", "slow", "collision"]


def test_html_embeds_header_and_data(recording, tmp_path):
    out = write_html(recording, tmp_path / "p.html")
    text = out.read_text()
    header = json.loads(re.search(r'id="fftnav-header">(.*?)</script>', text, re.S).group(1))
    data = base64.b64decode(re.search(r'id="fftnav-data">(.*?)</script>', text, re.S).group(1))
    assert header["ticks"] == TICKS + 1 and header["picked"] == 1  # the first not to arrive
    assert _arrays(header, data)["pose"].size == (TICKS + 1) * 4 * 3


def test_bad_window_and_robot(recording):
    with pytest.raises(ValueError, match=r"from_s must be <= to_s, got from_s=3.0, to_s=1.0"):
        player_data(recording, from_s=3, to_s=1)
    with pytest.raises(ValueError, match=r"robot must be an integer in \[0, 3\], got robot=7"):
        player_data(recording, robot=7)


def test_the_estimated_poses_are_in_the_data_only_when_recorded(recording, tmp_path):
    header, data = player_data(recording)
    assert header["estimates"] is False and "estimate" not in header["arrays"]
    make_recording(tmp_path / "e.npz", estimates=True)
    header, data = player_data(read_recording(tmp_path / "e.npz"), from_s=1.0, to_s=3.0)
    assert header["estimates"] is True
    assert header["estimateLabels"] == {"truth": TRUTH_LABEL, "estimate": ESTIMATE_LABEL}
    g = header["ticks"]
    a = _arrays(header, data)
    est = a["estimate"].reshape(g, 4, 3)
    for k, tick in enumerate(range(10, 31)):
        np.testing.assert_allclose(est[k], [estimate(i, tick) for i in range(4)], atol=1e-5)
        np.testing.assert_allclose(a["pose"].reshape(g, 4, 3)[k],
                                   [pose(i, tick) for i in range(4)], atol=1e-5)
