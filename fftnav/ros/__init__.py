"""ROS 1 and ROS 2 bags: LaserScan messages in, annotated bags and simulated episodes out.

The bag files are read and written with `rosbags <https://pypi.org/project/rosbags/>`_ (pure
Python, no ROS install), the optional extra ``fftnav[ros]``. It is imported only inside the
functions that open or write a bag, each after :func:`require_rosbags`, so fftnav works without
it; without it they raise :class:`fftnav.errors.MissingExtraError` (an ``ImportError``), one line
naming the pip line that installs it.

- :mod:`fftnav.ros.laserscan`: what a ``sensor_msgs/LaserScan`` means (field of view from its
  angles, REP 117 values), in numpy alone;
- :mod:`fftnav.ros.messages`: ROS messages built from plain values for any typestore;
- :mod:`fftnav.ros.bags`: opening and checking bags, streaming a topic's scans through the
  pipeline, writing the annotated bag;
- :mod:`fftnav.ros.episode`: an episode written as a bag (``fftnav episode --bag``).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from fftnav.errors import FftnavError, import_extra

__all__ = ["BAG_SUFFIXES", "check_not_special", "is_bag", "require_rosbags"]

#: File names read as bags (any case): a ROS 1 bag, a ROS 2 sqlite3 or MCAP storage file.
BAG_SUFFIXES = (".bag", ".db3", ".mcap")


def require_rosbags() -> None:
    """Raise :class:`fftnav.errors.MissingExtraError` unless rosbags can be imported: every
    function of this package that imports rosbags calls it first.

    Raises
    ------
    MissingExtraError
        ``ROS bags need the rosbags package: pip install 'fftnav[ros]'``.
    """
    import_extra("rosbags", extra="ros", needed_for="ROS bags")


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` names a bag: a ``.bag``, ``.db3`` or ``.mcap`` file (any case) or a
    ROS 2 bag folder (a folder holding ``metadata.yaml``).

    >>> is_bag("run.BAG"), is_bag("run.mcap"), is_bag("scans.npy")
    (True, True, False)
    """
    path = Path(path)
    if path.name.lower().endswith(BAG_SUFFIXES):
        return True
    return path.is_dir() and (path / "metadata.yaml").is_file()


def check_not_special(path: str | Path, what: str = "a bag") -> None:
    """Refuse a pipe, FIFO, socket or device by ``stat``, without opening it (opening a FIFO
    blocks until a writer comes); a missing path raises FileNotFoundError."""
    mode = os.stat(path).st_mode
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise FftnavError(f"{path}: {what} must be a regular file or a ROS 2 bag folder, "
                          "not a pipe, FIFO, socket or device")
