"""Input and output paths: every reader refuses a FIFO or a device by ``stat`` (never opening
it, so never blocking), every writer writes atomically, through a symbolic link, never over a
FIFO or a device, and names the user's path (never its temporary file) when it cannot write."""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fftnav.files import (
    atomic_path,
    check_input,
    check_target,
    iter_csv_rows,
    iter_npy_rows,
    load_npy,
    load_npz,
    read_json,
    read_text,
    read_toml,
    write_atomic,
)


@pytest.fixture
def fifo(tmp_path):
    """A named pipe nobody writes to: opening it for reading would block forever."""
    def make(name: str) -> Path:
        path = tmp_path / name
        os.mkfifo(path)
        return path

    signal.signal(signal.SIGALRM, lambda *_: pytest.fail("a reader blocked on a FIFO"))
    signal.alarm(60)
    yield make
    signal.alarm(0)


def _readers():
    from fftnav.episode.recording import read_recording
    from fftnav.observe.scanio import iter_scans, read_scans
    from fftnav.runner import load_config
    from fftnav.world import load_world
    from fftnav.world.kinds import load_preset
    from fftnav.world.rosmap import read_pgm, read_robots_toml, read_ros_map

    return [
        ("t.txt", read_text), ("w.json", read_json), ("c.toml", read_toml),
        ("a.npy", load_npy), ("a.npz", load_npz), ("s.csv", lambda p: list(iter_csv_rows(p))),
        ("s.npy", lambda p: list(iter_npy_rows(p))), ("s.npy", read_scans),
        ("s.csv", read_scans), ("s.log", read_scans),
        ("s.csv", lambda p: list(iter_scans(p).chunks)), ("w.json", load_world),
        ("c.toml", load_config), ("r.npz", read_recording), ("m.yaml", read_ros_map),
        ("m.pgm", read_pgm), ("r.toml", read_robots_toml), ("p.toml", load_preset),
    ]


@pytest.mark.parametrize("index", range(18))
def test_every_reader_refuses_a_fifo_without_opening_it(fifo, index):
    name, reader = _readers()[index]
    path = fifo(name)
    with pytest.raises(ValueError, match=rf"{name.replace('.', '[.]')}: is a named pipe "
                                         r"\(FIFO\), not a file; give a regular file"):
        reader(path)


def test_a_map_image_that_is_a_fifo_is_refused(fifo, tmp_path):
    from fftnav.world.rosmap import read_ros_map

    for image in ("m.pgm", "m.png"):
        fifo(image)
        (tmp_path / "m.yaml").write_text(f"image: {image}\nresolution: 0.05\norigin: [0, 0, 0]\n")
        with pytest.raises(ValueError, match=rf"{image}: is a named pipe \(FIFO\)"):
            read_ros_map(tmp_path / "m.yaml")


def test_devices_and_folders_are_refused_as_inputs(tmp_path):
    with pytest.raises(ValueError, match=r"/dev/null: is a character device, not a file"):
        check_input("/dev/null")
    with pytest.raises(ValueError, match=rf"{tmp_path}: is a folder, not a file"):
        read_text(tmp_path)
    with pytest.raises(FileNotFoundError):
        check_input(tmp_path / "missing.json")


@pytest.mark.parametrize("argv", [
    ["scan", "{fifo}.npy"], ["scan", "{fifo}.csv"], ["scan3d", "{fifo}.npy"],
    ["episode", "--world", "{fifo}.json", "--policy", "fusion"],
    ["run", "{fifo}.toml"], ["world", "render", "{fifo}.json", "--out", "{tmp}/w.png"],
    ["world", "import", "{fifo}.yaml", "--start", "1", "1", "0", "--goal", "2", "2",
     "--out", "{tmp}/w.json"],
    ["replay", "{fifo}.npz", "--out", "{tmp}/r.html"],
])
def test_commands_refuse_a_fifo_input_in_one_line_without_blocking(tmp_path, argv):
    stem = tmp_path / "in"
    suffix = Path(next(a for a in argv if a.startswith("{fifo}"))).suffix
    os.mkfifo(f"{stem}{suffix}")
    argv = [a.format(fifo=stem, tmp=tmp_path) for a in argv]
    proc = subprocess.run([sys.executable, "-m", "fftnav", *argv], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr
    assert proc.stderr == (f"fftnav {argv[0]}: error: {stem}{suffix}: is a named pipe (FIFO), "
                           "not a file; give a regular file\n")


# ----------------------------------------------------------------------------- outputs


def test_output_paths_that_cannot_be_written_are_refused_naming_them(tmp_path, fifo):
    with pytest.raises(ValueError, match=rf"--out must be a file path, not a folder, got "
                                         rf"--out='{tmp_path}'$"):
        check_target(tmp_path, flag="--out")
    with pytest.raises(ValueError, match=r"--out must be in an existing folder, got "
                                         r"--out='.*/no/w\.json' \(no folder '.*/no'\)$"):
        check_target(tmp_path / "no" / "w.json", flag="--out")
    assert check_target(tmp_path / "no" / "w.json", make_folder=True) == tmp_path / "no/w.json"
    with pytest.raises(ValueError, match=r"--out must be a file path, not a named pipe \(FIFO\)"
                                         r", got --out='.*p\.csv'$"):
        check_target(fifo("p.csv"), flag="--out")
    with pytest.raises(ValueError, match=r"path must be a file path, not a character device, "
                                         r"got path='/dev/full'$"):
        write_atomic("/dev/full", "x")
    with pytest.raises(ValueError, match=r"--plot must end in the image's type, e\.g\. \.png"):
        check_target(tmp_path / "plot", flag="--plot", image=True)


def test_a_symbolic_link_is_written_through_and_kept(tmp_path, fifo):
    (tmp_path / "real.csv").write_text("old")
    (tmp_path / "link.csv").symlink_to(tmp_path / "real.csv")
    write_atomic(tmp_path / "link.csv", "new")
    assert (tmp_path / "link.csv").is_symlink() and (tmp_path / "real.csv").read_text() == "new"
    (tmp_path / "to_fifo").symlink_to(fifo("f"))
    with pytest.raises(ValueError, match=r"not a named pipe \(FIFO\), got path='.*to_fifo'"):
        write_atomic(tmp_path / "to_fifo", "x")
    assert (tmp_path / "to_fifo").is_symlink() and Path(tmp_path / "f").is_fifo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f", "link.csv", "real.csv", "to_fifo"]


def test_a_full_disk_names_the_path_and_leaves_no_file(tmp_path):
    with pytest.raises(OSError, match=r"\[Errno 28\] cannot write '.*out\.png': No space left"
                                      r" on device$"):
        with atomic_path(tmp_path / "out.png", keep_suffix=True) as tmp:
            assert tmp.suffix == ".png" and tmp.parent == tmp_path
            tmp.write_bytes(b"half an image")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert list(tmp_path.iterdir()) == []


def _full_disk_savefig(self, fname, *args, **kwargs):
    """Figure.savefig on a full disk: part of the image written, then ENOSPC."""
    Path(fname).write_bytes(b"\x89PNG half")
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_world_render_on_a_full_disk_names_the_path_and_leaves_no_file(tmp_path, monkeypatch,
                                                                        capsys):
    from fftnav.cli import main
    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=3),
               tmp_path / "w.json")
    out = tmp_path / "pics"
    out.mkdir()
    monkeypatch.setattr("matplotlib.figure.Figure.savefig", _full_disk_savefig)
    assert main(["world", "render", str(tmp_path / "w.json"), "--out", str(out / "w.png")]) == 2
    assert capsys.readouterr().err == (f"fftnav world: error: [Errno 28] cannot write "
                                       f"'{out / 'w.png'}': No space left on device\n")
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("flag", ["--out", "--record", "--trajectories", "--plot"])
def test_episode_outputs_on_a_full_disk_name_their_path(tmp_path, monkeypatch, capsys, flag):
    from fftnav.cli import main
    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=2),
               tmp_path / "w.json")
    out = tmp_path / "out"
    target = out / {"--out": "e.csv", "--record": "r.npz", "--trajectories": "t.npz",
                    "--plot": "p.png"}[flag]
    if flag == "--plot":
        monkeypatch.setattr("matplotlib.figure.Figure.savefig", _full_disk_savefig)
    else:
        real = os.replace

        def replace(src, dst):
            if Path(dst) == target:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            real(src, dst)

        monkeypatch.setattr("fftnav.files.os.replace", replace)
    status = main(["episode", "--world", str(tmp_path / "w.json"), "--policy", "fusion",
                   "--set", "time_limit_s=1", flag, str(target)])
    err = capsys.readouterr().err
    assert status == 2 and err == (f"fftnav episode: error: [Errno 28] cannot write "
                                   f"'{target}': No space left on device\n")
    assert list(out.iterdir()) == []


@pytest.mark.parametrize(("argv", "message"), [
    (["world", "render", "{w}", "--out", "{tmp}"],
     "fftnav world: error: --out must be a file path, not a folder, got --out='{tmp}'"),
    (["world", "render", "{w}", "--out", "{tmp}/no/w.png"],
     "fftnav world: error: --out must be in an existing folder, got --out='{tmp}/no/w.png' "
     "(no folder '{tmp}/no')"),
    (["world", "generate", "--env", "forest", "--seed", "1", "--out", "{tmp}/no/w.json"],
     "fftnav world: error: --out must be in an existing folder, got --out='{tmp}/no/w.json' "
     "(no folder '{tmp}/no')"),
    (["world", "import", "{tmp}/m.yaml", "--start", "1", "1", "0", "--goal", "2", "2",
      "--out", "{tmp}"],
     "fftnav world: error: --out must be a file path, not a folder, got --out='{tmp}'"),
    (["world", "grid", "{w}", "--out", "{tmp}/g.npy", "--ros-map", "{tmp}/no/m"],
     "fftnav world: error: --ros-map must be in an existing folder, got "
     "--ros-map='{tmp}/no/m.pgm' (no folder '{tmp}/no')"),
    (["world", "render", "{w}", "--out", "/proc/self/fd/1"],
     "fftnav world: error: --out must be a file path, not a named pipe (FIFO), got "
     "--out='/proc/self/fd/1'"),
    (["episode", "--world", "{w}", "--policy", "fusion", "--plot", "{tmp}"],
     "fftnav episode: error: --plot must be a file path, not a folder, got --plot='{tmp}'"),
    (["episode", "--world", "{w}", "--policy", "fusion", "--plot", "{tmp}/p"],
     "fftnav episode: error: --plot must end in the image's type, e.g. .png or .svg, got "
     "--plot='{tmp}/p'"),
    (["fly3d", "--seeds", "1", "--out", "{tmp}"],
     "fftnav fly3d: error: --out must be a file path, not a folder, got --out='{tmp}'"),
    (["fly3d", "--seeds", "1", "--out", "{tmp}/f.csv", "--plot", "{tmp}/p"],
     "fftnav fly3d: error: --plot must end in the image's type, e.g. .png or .svg, got "
     "--plot='{tmp}/p'"),
    (["episode", "--world", "{w}", "--policy", "fusion", "--out", "/dev/full"],
     "fftnav episode: error: --out must be a file path, not a character device, got "
     "--out='/dev/full'"),
])
def test_cli_output_paths_are_refused_before_the_work_naming_the_users_path(tmp_path, argv,
                                                                            message):
    from fftnav.world import generate_world, save_world

    work = tmp_path / "in"
    work.mkdir()
    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=2),
               work / "w.json")
    out = tmp_path / "out"
    out.mkdir()
    argv = [a.format(w=work / "w.json", tmp=out) for a in argv]
    proc = subprocess.run([sys.executable, "-m", "fftnav", *argv], capture_output=True,
                          text=True, timeout=120)  # stdout is a pipe: /proc/self/fd/1 too
    assert proc.returncode == 2 and ".tmp" not in proc.stderr, proc.stderr
    assert proc.stderr == message.format(tmp=out) + "\n"
    assert list(out.iterdir()) == [] and not (tmp_path / "out.png").exists()


def test_world_render_writes_through_a_link_and_atomically(tmp_path):
    from fftnav.cli import main
    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=2),
               tmp_path / "w.json")
    (tmp_path / "real.png").write_bytes(b"old")
    (tmp_path / "link.png").symlink_to(tmp_path / "real.png")
    assert main(["world", "render", str(tmp_path / "w.json"), "--out",
                 str(tmp_path / "link.png")]) == 0
    assert (tmp_path / "link.png").is_symlink()
    assert (tmp_path / "real.png").read_bytes()[:4] == b"\x89PNG"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.png", "real.png", "w.json"]


def test_npy_rows_and_csv_rows_agree_with_the_whole_file_readers(tmp_path):
    scans = np.random.default_rng(2).uniform(0, 5, (33, 7))
    np.save(tmp_path / "s.npy", scans)
    np.testing.assert_array_equal(np.concatenate(list(iter_npy_rows(tmp_path / "s.npy",
                                                                    rows=5))),
                                  load_npy(tmp_path / "s.npy"))
    (tmp_path / "s.csv").write_text("\n".join(",".join(map(repr, row.tolist())) for row in scans))
    np.testing.assert_array_equal(np.concatenate(list(iter_csv_rows(tmp_path / "s.csv",
                                                                    rows=4))), scans)


def test_json_depth_is_counted_across_pieces_of_a_mebibyte():
    from fftnav.files import json_depth

    deep = "[" * 70 + " " * (1 << 20) + "]" * 70  # the deepest point spans two pieces
    assert json_depth(deep) == 70 and json_depth('"[[[" ' + deep) == 70
    assert json_depth("[" * 3 + "]" * 3 + " " * (1 << 21) + "{}") == 3 and json_depth("") == 0
    with pytest.raises(ValueError, match=r"w\.json: JSON nested 70 levels deep, above the limit "
                                         r"of 64"):
        from fftnav.files import parse_json

        parse_json(deep, where="w.json")


def test_a_float32_signalling_nan_streams_as_nan_without_a_warning(tmp_path):
    import warnings

    scans = np.ones((2, 8), dtype=np.float32)
    scans.view(np.uint32)[1, 3] = 0x7FA00000  # a signalling NaN
    np.save(tmp_path / "s.npy", scans)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rows = np.concatenate(list(iter_npy_rows(tmp_path / "s.npy")))
    assert np.isnan(rows[1, 3]) and np.isnan(rows).sum() == 1


def test_an_input_missing_inside_a_write_keeps_its_own_error(tmp_path):
    """Only the write's own errors are renamed: a file the block reads keeps its name."""
    with pytest.raises(FileNotFoundError, match=r"in\.csv"):
        with atomic_path(tmp_path / "out.csv") as tmp:
            tmp.write_text("x")
            (tmp_path / "in.csv").read_text()
    assert list(tmp_path.iterdir()) == []


def test_a_writer_sweeps_the_temporaries_a_killed_writer_left_beside_its_target(tmp_path):
    """SIGKILL skips every cleanup: the next command naming the same output (check_target,
    before its work) removes the dead process's temporary files of that path (and of no other
    path, nor a live process's)."""
    import subprocess
    import sys

    from fftnav.files import check_target, remove_stale_temporaries_of, write_atomic

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    stale = [tmp_path / f".r.gif.{dead}.tmp.gif", tmp_path / f".r.gif.{dead}.tmp"]
    kept = [tmp_path / f".r.gif.{os.getpid()}.tmp.gif",  # this process: alive
            tmp_path / f".other.gif.{dead}.tmp.gif", tmp_path / "r.gif.tmp"]
    for path in (*stale, *kept):
        path.write_text("x")
    check_target(tmp_path / "r.gif")
    write_atomic(tmp_path / "r.gif", b"GIF89a")
    assert [p.exists() for p in stale] == [False, False]
    assert all(p.exists() for p in kept)
    assert remove_stale_temporaries_of(tmp_path / "other.gif") == 1


# ------------------------------------------------- a temporary that cannot be made (read-only)


def _refuse_temporaries(monkeypatch, code: int) -> None:
    """Making a temporary file (``os.open``) or a bag's temporary folder (``Path.mkdir``) fails
    with ``code``, as the kernel answers in a folder that is not writable (EACCES), on a
    read-only file system (EROFS) or on a full disk (ENOSPC); everything else is made."""
    from fftnav.files import is_temporary

    real_open, real_mkdir = os.open, Path.mkdir

    def refuse(path):
        raise OSError(code, os.strerror(code), os.fspath(path))

    def fake_open(path, flags, *args, **kwargs):
        if is_temporary(Path(path)):
            refuse(path)
        return real_open(path, flags, *args, **kwargs)

    def fake_mkdir(self, *args, **kwargs):
        if is_temporary(self):
            refuse(self)
        return real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr("fftnav.files.os.open", fake_open)
    monkeypatch.setattr(Path, "mkdir", fake_mkdir)


#: What each refusal reads as, for the folder ``{f}``.
_REASONS = {errno.EACCES: "permission denied: the folder {f} is not writable",
            errno.EROFS: "read-only file system: the folder {f} cannot be written",
            errno.ENOSPC: "no space left on the device of the folder {f}"}


def _write_atomic(path):
    write_atomic(path, "x")


def _atomic_writer(path):
    from fftnav.files import atomic_writer

    with atomic_writer(path) as fh:
        fh.write(b"x")


def _atomic_path(path):
    with atomic_path(path, keep_suffix=True) as tmp:
        tmp.write_bytes(b"x")


def _bag_file(path):
    pytest.importorskip("rosbags")
    from fftnav.ros.bags import BagWriter

    with BagWriter(path, ros1=False, storage="mcap", single=True):
        pass


@pytest.mark.parametrize("code", list(_REASONS))
@pytest.mark.parametrize("write", [_write_atomic, _atomic_writer, _atomic_path, _bag_file])
def test_a_temporary_that_cannot_be_made_names_the_users_path_and_why(tmp_path, monkeypatch,
                                                                        write, code):
    _refuse_temporaries(monkeypatch, code)
    monkeypatch.chdir(tmp_path)
    reason = _REASONS[code].format(f=tmp_path)
    with pytest.raises(ValueError, match=rf"^out\.csv: cannot write here "
                                         rf"\({re.escape(reason)}\)$"):
        write("out.csv")
    assert list(tmp_path.iterdir()) == []


def test_a_bag_folder_in_missing_folders_names_the_nearest_existing_one(tmp_path, monkeypatch):
    """mkdir(parents=True) makes the missing folders first: the folder that refused is the
    nearest one that exists."""
    _refuse_temporaries(monkeypatch, errno.EACCES)
    with pytest.raises(ValueError, match=rf"^{re.escape(str(tmp_path))}/a/b/x\.mcap: cannot "
                                         rf"write here \(permission denied: the folder "
                                         rf"{re.escape(str(tmp_path))} is not writable\)$"):
        _bag_file(tmp_path / "a" / "b" / "x.mcap")


def test_the_cli_says_so_in_one_line_exit_2(tmp_path, monkeypatch, capsys):
    pytest.importorskip("rosbags")
    from fftnav.cli import main
    from tests.ros.bagmaker import scans_bag

    bag = scans_bag(tmp_path / "b.mcap", np.full((2, 90), 5.0))
    out = tmp_path / "out"
    out.mkdir()
    _refuse_temporaries(monkeypatch, errno.EACCES)
    why = f"cannot write here (permission denied: the folder {out} is not writable)"
    assert main(["world", "generate", "--env", "forest", "--seed", "3", "--size", "8", "8",
                 "--out", str(out / "w.json")]) == 2
    assert capsys.readouterr().err == f"fftnav world: error: {out / 'w.json'}: {why}\n"
    assert main(["scan", str(bag), "--out-bag", str(out / "a.mcap")]) == 2
    captured = capsys.readouterr()
    assert captured.err == f"fftnav scan: error: {out / 'a.mcap'}: {why}\n"
    assert list(out.iterdir()) == []


def test_a_writers_own_message_names_the_users_path_not_the_temporary(tmp_path, monkeypatch,
                                                                       capsys):
    """A ValueError of the block that names the temporary file (a video writer's "could not be
    written") names the user's path; one naming another file is left alone."""
    from fftnav.cli import main
    from fftnav.errors import FftnavError
    from fftnav.report import replay
    from tests.report.recordings import make_recording

    with pytest.raises(ValueError, match=rf"^{re.escape(str(tmp_path))}/r\.gif: the GIF could "
                                         r"not be written \(no space left on device\)$"):
        with atomic_path(tmp_path / "r.gif", keep_suffix=True) as tmp:
            raise FftnavError(f"{tmp}: the GIF could not be written (no space left on device)")
    with pytest.raises(ValueError, match=r"^in\.csv: bad$"):
        with atomic_path(tmp_path / "r.gif", keep_suffix=True):
            raise FftnavError("in.csv: bad")
    assert list(tmp_path.iterdir()) == []

    def full_disk(path, frames, fps):
        next(iter(frames))
        Path(path).write_bytes(b"GIF89a")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    make_recording(tmp_path / "r.npz")
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.setattr(replay, "_write_gif", full_disk)
    assert main(["replay", str(tmp_path / "r.npz"), "--out", str(out / "r.gif")]) == 2
    assert capsys.readouterr().err == (f"fftnav replay: error: {out / 'r.gif'}: the GIF could "
                                       f"not be written (no space left on device)\n")
    assert list(out.iterdir()) == []
