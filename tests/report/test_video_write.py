"""Videos are read back before they count: a GIF or MP4 that does not decode to every frame (a
full disk cuts it short) is an error in one line, and the CLI leaves no file under the real
name."""

from __future__ import annotations

import errno

import pytest

from fftnav.cli import main
from fftnav.report import replay
from fftnav.report.replay import frame_ticks, write_video
from tests.report.recordings import make_recording


def _frames(recording):
    return len(frame_ticks(recording, from_s=1.0, to_s=3.0, speed=10))


def test_a_gif_cut_short_is_refused(recording, tmp_path, monkeypatch):
    real = replay._write_gif

    def cut(path, frames, fps):
        real(path, frames, fps)
        data = path.read_bytes()
        path.write_bytes(data[:len(data) // 2])  # what a full disk leaves

    monkeypatch.setattr(replay, "_write_gif", cut)
    with pytest.raises(ValueError, match=r"r\.gif: the written video (does not decode|decodes "
                                         r"to \d+ frames, not \d+); is the disk full\?$"):
        write_video(recording, tmp_path / "r.gif", from_s=1.0, to_s=3.0, speed=10)


def test_a_written_gif_decodes_to_every_frame(recording, tmp_path):
    from PIL import Image

    path = write_video(recording, tmp_path / "r.gif", from_s=1.0, to_s=3.0, speed=10)
    with Image.open(path) as image:
        assert image.n_frames == _frames(recording)


def test_a_full_disk_while_writing_is_one_line(recording, tmp_path, monkeypatch):
    def full(path, frames, fps):
        next(iter(frames))
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(replay, "_write_gif", full)
    with pytest.raises(ValueError, match=r"^.*r\.gif: the GIF could not be written \(no space "
                                         r"left on device\)$"):
        write_video(recording, tmp_path / "r.gif", from_s=1.0, to_s=3.0, speed=10)


def test_ffmpegs_many_lines_become_one(recording, tmp_path, monkeypatch):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")

    def failing(*args, **kwargs):
        yield
        raise OSError("[Errno 32] Broken pipe\n\nFFMPEG COMMAND:\nffmpeg -y ...\n\nFFMPEG STDERR "
                      "OUTPUT:\nav_interleaved_write_frame(): No space left on device\n"
                      "Error writing trailer of r.mp4: No space left on device\n")

    monkeypatch.setattr(imageio_ffmpeg, "write_frames", failing)
    with pytest.raises(ValueError, match=r"r\.mp4: the MP4 could not be written \(no space left "
                                         r"on device\)$") as caught:
        write_video(recording, tmp_path / "r.mp4", from_s=1.0, to_s=3.0, speed=10)
    assert "\n" not in str(caught.value)


def test_a_written_mp4_decodes_to_every_frame(recording, tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    path = write_video(recording, tmp_path / "r.mp4", from_s=1.0, to_s=3.0, speed=10)
    assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == _frames(recording)


def test_the_cli_leaves_nothing_under_the_real_name(tmp_path, monkeypatch, capsys):
    make_recording(tmp_path / "r.npz")
    real = replay._write_gif

    def cut(path, frames, fps):
        real(path, frames, fps)
        path.write_bytes(path.read_bytes()[:100])

    monkeypatch.setattr(replay, "_write_gif", cut)
    out = tmp_path / "v" / "r.gif"
    code = main(["replay", str(tmp_path / "r.npz"), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "is the disk full?" in err
    assert not out.exists() and list(out.parent.iterdir()) == []  # no temporary left either
