"""Shared fixtures of the report tests."""

from __future__ import annotations

import pytest

from fftnav.episode.recording import read_recording
from tests.report.recordings import make_recording


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """The hand-made recording of :mod:`tests.report.recordings`, read back."""
    path = tmp_path_factory.mktemp("rec") / "r.npz"
    make_recording(path)
    return read_recording(path)
