"""``fftnav replay`` as a subprocess: each format's file, and bad input as one line, exit 2."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from tests.report.recordings import TICKS, make_recording

ROOT = Path(__file__).resolve().parents[2]


def _fftnav(*args, code=None):
    cmd = code or "from fftnav.cli import main; import sys; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", cmd, *map(str, args)], capture_output=True,
                          text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, cwd=ROOT)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "r.npz"
    make_recording(path)
    return path


def test_png_is_one_frame(recording, tmp_path):
    out = tmp_path / "f.png"
    done = _fftnav("replay", recording, "--out", out, "--at", "3.5", "--robot", "2")
    assert done.returncode == 0, done.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert re.fullmatch(rf"{re.escape(str(out))}: \d+\.\d\d MB\n", done.stderr)


def test_gif_has_one_frame_per_tenth_of_a_second_times_speed(recording, tmp_path):
    out = tmp_path / "r.gif"
    done = _fftnav("replay", recording, "--out", out, "--from", "1", "--to", "5", "--speed", "2")
    assert done.returncode == 0, done.stderr
    assert out.read_bytes()[:6] == b"GIF89a"
    with Image.open(out) as gif:  # 1 .. 5 s every 0.2 s
        assert gif.n_frames == 21 and gif.info["duration"] == 100


def test_mp4(recording, tmp_path):
    pytest.importorskip("imageio_ffmpeg", reason="the optional extra fftnav[video]")
    out = tmp_path / "r.mp4"
    done = _fftnav("replay", recording, "--out", out, "--speed", "4")
    assert done.returncode == 0, done.stderr
    assert out.read_bytes()[4:8] == b"ftyp"


def test_mp4_without_imageio_ffmpeg_says_how_to_install_it(recording, tmp_path):
    block = ("import sys; sys.modules['imageio_ffmpeg'] = None; from fftnav.cli import main; "
             "sys.exit(main(sys.argv[1:]))")
    done = _fftnav("replay", recording, "--out", tmp_path / "r.mp4", code=block)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "pip install 'fftnav[video]'" in done.stderr
    assert not (tmp_path / "r.mp4").exists()


def test_html_is_self_contained(recording, tmp_path):
    out = tmp_path / "r.html"
    done = _fftnav("replay", recording, "--out", out)
    assert done.returncode == 0, done.stderr
    text = out.read_text()
    assert text.startswith("<!DOCTYPE html>") and "window.fftnavPlayer" in text
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", text, re.I)
    assert "http://" not in text and "https://" not in text
    assert not re.search(r"<(link|img|iframe)\b|<script[^>]*\ssrc=|@import|url\(", text, re.I)
    assert "FFTNAV_DATA" not in text and "/*FFTNAV_HEADER*/" not in text
    assert f'"ticks":{TICKS + 1}' in text


@pytest.mark.parametrize(("args", "message"), [
    (["--robot", "4"], r"--robot must be an integer in \[0, 3\], got --robot=4"),
    (["--robot", "-1"], r"--robot must be an integer in \[0, 3\], got --robot=-1"),
    (["--from", "4", "--to", "2"], r"--from must be <= --to, got --from=4.0, --to=2.0"),
    (["--to", "9"], r"--to must be a finite number in \[0, 6\], got --to=9.0"),
    (["--speed", "0"], r"--speed must be a finite number in \[0.1, 1000\], got --speed=0.0"),
])
def test_bad_arguments_are_one_line_and_exit_2(recording, tmp_path, args, message):
    done = _fftnav("replay", recording, "--out", tmp_path / "r.gif", *args)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert re.search(message, done.stderr), done.stderr
    assert not (tmp_path / "r.gif").exists()


def test_bad_format_and_unreadable_recording(recording, tmp_path):
    done = _fftnav("replay", recording, "--out", tmp_path / "r.txt")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "--out must end in one of .html, .gif, .mp4, .png, got --out=" in done.stderr
    bad = tmp_path / "bad.npz"
    bad.write_text("not a recording")
    done = _fftnav("replay", bad, "--out", tmp_path / "r.png")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "path must be an fftnav recording, got path=" in done.stderr
    done = _fftnav("replay", tmp_path / "missing.npz", "--out", tmp_path / "r.png")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "missing.npz" in done.stderr
    done = _fftnav("replay", recording, "--out", tmp_path / "r.png", "--from", "1")
    assert done.returncode == 2 and "a .png is one frame: pick it with --at S" in done.stderr


def test_recordings_side_by_side_are_each_frame_next_to_the_other(recording, tmp_path):
    import json

    import numpy as np

    with np.load(recording) as npz:  # a second recording: another policy name in its title
        cols = {k: npz[k] for k in npz.files}
    meta = json.loads(cols["meta"].tobytes())
    cols["meta"] = np.frombuffer(json.dumps({**meta, "policy": "other"}).encode(), np.uint8)
    other = tmp_path / "other.npz"
    np.savez_compressed(other, **cols)
    paths = {"one": [recording], "two": [other], "pair": [recording, other]}
    images = {}
    for name, sources in paths.items():
        done = _fftnav("replay", *sources, "--out", tmp_path / f"{name}.png", "--at", "2")
        assert done.returncode == 0, done.stderr
        images[name] = np.asarray(Image.open(tmp_path / f"{name}.png"))
    width = images["one"].shape[1]
    assert images["pair"].shape == (images["one"].shape[0], 2 * width, images["one"].shape[2])
    assert not np.array_equal(images["one"], images["two"])
    np.testing.assert_array_equal(images["pair"][:, :width], images["one"])
    np.testing.assert_array_equal(images["pair"][:, width:], images["two"])
    html = _fftnav("replay", recording, other, "--out", tmp_path / "x.html", "--robot", "2")
    assert html.returncode == 0, html.stderr
    text = (tmp_path / "x.html").read_text()  # one page, a pane and a data block each
    panes = json.loads(re.search(r'id="fftnav-header">(.*?)</script>', text, re.S)
                       .group(1))["panes"]
    assert [p["title"].split(" on ")[0] for p in panes] == ["by-hand", "other"]
    assert [p["picked"] for p in panes] == [2, 2]
    assert 'id="fftnav-data-0"' in text and 'id="fftnav-data-1"' in text


# --- recordings made on demand: fftnav replay RESULTS_DIR --task TASK -------------------------


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    from tests.report.small_results import make_small_results

    return make_small_results(tmp_path_factory.mktemp("small"))


def _columns(path):
    import numpy as np

    with np.load(path) as npz:
        return {k: npz[k] for k in npz.files}


def test_a_task_of_a_results_folder_is_rerun_into_the_recording_the_run_kept(small, tmp_path):
    import numpy as np

    from tests.report.small_results import TASKS, fftnav

    report = (small / "report.md").read_text()
    assert all(f"`{task}`" in report for task in TASKS)  # every episode failed
    kept = small / "records" / "forest-8-fusion.npz"
    oracle = _columns(kept)
    kept.unlink()  # as in a clone: no recording beside the results
    made = tmp_path / "made.npz"
    code = ("import sys; from fftnav.runner.rerun import rerun_task; "
            "open(sys.argv[3], 'wb').write(rerun_task(sys.argv[1], sys.argv[2]).result.recording)")
    done = _fftnav(small, "forest-8-fusion", made, code=code)
    assert done.returncode == 0, done.stderr
    columns = _columns(made)
    assert columns.keys() == oracle.keys()
    for name, array in oracle.items():
        np.testing.assert_array_equal(columns[name], array, err_msg=name)
    out = tmp_path / "r.html"
    done = fftnav("replay", small, "--task", "forest-8-fusion", "--out", out, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert re.fullmatch(rf"{re.escape(str(out))}: \d+\.\d\d MB \(rerun of forest-8-fusion: the "
                        rf"rows of {re.escape(str(small / 'episodes.csv'))}\)\n", done.stderr)
    assert '"title":"fusion on forest (map seed 8, episode seed ' in out.read_text()


def test_tasks_side_by_side_are_one_frame_each(small, tmp_path):
    import numpy as np

    from tests.report.small_results import fftnav

    images = {}
    for name, tasks in {"one": ["forest-7-bug-left"], "pair": ["forest-7-bug-left",
                                                               "forest-7-fusion"]}.items():
        args = [a for task in tasks for a in ("--task", task)]
        done = fftnav("replay", small, *args, "--out", tmp_path / f"{name}.png", "--at", "3")
        assert done.returncode == 0, done.stderr
        images[name] = np.asarray(Image.open(tmp_path / f"{name}.png"))
    width = images["one"].shape[1]
    assert images["pair"].shape[1] == 2 * width
    np.testing.assert_array_equal(images["pair"][:, :width], images["one"])


def test_a_rerun_whose_rows_differ_from_the_folders_is_refused_in_one_line(small, tmp_path):
    import shutil

    from tests.report.small_results import fftnav

    changed = tmp_path / "changed"
    shutil.copytree(small, changed, ignore=shutil.ignore_patterns("records", "episodes"))
    lines = (changed / "episodes.csv").read_text().splitlines(keepends=True)
    header = lines[0].rstrip("\n").split(",")
    at = next(i for i, line in enumerate(lines) if line.startswith("forest,7,fusion,")
              and line.split(",")[header.index("robot")] == "1")
    fields = lines[at].rstrip("\n").split(",")
    fields[header.index("path_length_m")] = "99.000000"
    lines[at] = ",".join(fields) + "\n"
    (changed / "episodes.csv").write_text("".join(lines))
    out = tmp_path / "r.html"
    done = fftnav("replay", changed, "--task", "forest-7-fusion", "--out", out)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert re.search(r"the rerun of forest-7-fusion must give the rows of .*episodes\.csv, got "
                     r"other rows \(robot 1: path_length_m \d+\.\d{6} here, 99\.000000 in the "
                     r"folder\)", done.stderr), done.stderr
    assert not out.exists()
    done = fftnav("replay", changed, "--task", "forest-8-fusion", "--out", out)
    assert done.returncode == 0, done.stderr  # the other episodes still reproduce


@pytest.mark.parametrize(("where", "task", "message"), [
    ("small", "forest-7-fusoin", r"--task must be an episode of .*episodes\.csv, got "
     r"--task='forest-7-fusoin'; did you mean forest-7-fusion"),
    ("smal", "forest-7-fusion", r"RESULTS_DIR must be a results folder of fftnav run \(with "
     r"config\.toml and episodes\.csv\), got RESULTS_DIR='.*smal'; did you mean .*small\?"),
    (".", "forest-7-fusion", r"RESULTS_DIR must be a results folder .*; it holds the results "
     r"folders small$"),
])
def test_a_bad_folder_or_task_is_one_line_naming_the_close_ones(small, tmp_path, where, task,
                                                                  message):
    from tests.report.small_results import fftnav

    done = fftnav("replay", small.parent / where, "--task", task, "--out", tmp_path / "r.png")
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert re.search(message, done.stderr.strip()), done.stderr


def test_task_takes_one_folder(small, tmp_path):
    from tests.report.small_results import fftnav

    done = fftnav("replay", small, small, "--task", "forest-7-fusion", "--out", tmp_path / "r.png")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "--task names episodes of one results folder, got 2 paths" in done.stderr
