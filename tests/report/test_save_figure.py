"""fftnav.report.save_figure: figures are written whole or not at all."""

import matplotlib.figure
import pytest
from matplotlib.figure import Figure

from fftnav.report import save_figure


def test_a_figure_is_written_whole_under_its_name(tmp_path):
    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    out = save_figure(fig, tmp_path / "f.png", dpi=50)
    assert out == tmp_path / "f.png"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png"]


def test_a_failed_write_leaves_no_file_and_names_the_path(tmp_path, monkeypatch):
    """A disk that fills while the image is written: no partial file under the real name, no
    temporary file left, and the error names the path given."""
    real = matplotlib.figure.Figure.savefig

    def full_disk(self, fname, **kwargs):
        real(self, fname, **kwargs)  # the bytes are written, then the disk is full
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", full_disk)
    with pytest.raises(OSError, match="f.png"):
        save_figure(Figure(), tmp_path / "f.png")
    assert list(tmp_path.iterdir()) == []
