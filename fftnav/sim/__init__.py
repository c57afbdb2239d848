"""PyBullet simulation: the only package that imports pybullet (swarm, lidar, speed bench).

PyBullet prints a "pybullet build time" banner on stderr when first imported; it is silenced
here so that CLI errors stay one line.
"""

import os
import sys


def _import_pybullet_quietly() -> None:
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 2)
            import pybullet  # noqa: F401
    finally:
        os.dup2(saved, 2)
        os.close(saved)


_import_pybullet_quietly()
