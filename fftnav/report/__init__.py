"""Reports and figures: the only package that imports matplotlib.

Importing any module of this package selects matplotlib's non-interactive ``Agg`` backend first
(here, once), so figures are written to files without a display, also on headless machines.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")


def save_figure(fig, path, **savefig_kwargs) -> Path:
    """Write ``fig`` to ``path`` (format from its suffix) atomically: through a temporary file
    beside it, renamed over it when complete (:func:`fftnav.files.atomic_path`), so a full disk
    or an error leaves no partial image under the real name. Returns ``path``."""
    from fftnav.files import atomic_path

    with atomic_path(path, keep_suffix=True) as tmp:
        fig.savefig(tmp, **savefig_kwargs)
    return Path(path)
