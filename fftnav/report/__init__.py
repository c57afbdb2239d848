"""Reports and figures: the only package that imports matplotlib.

Every figure is a :class:`matplotlib.figure.Figure` drawn on its own Agg canvas
(:func:`new_figure`) and written by :func:`save_figure`: no pyplot, no global figure state, and
matplotlib's backend is never selected here, so importing this package or drawing a frame
(:meth:`fftnav.envs.SwarmNavEnv.render`) leaves a notebook's or a GUI's backend as it was, and
figures are written without a display.
"""

from pathlib import Path
from typing import Any

__all__ = ["new_figure", "save_figure"]


def new_figure(**figure_kwargs: Any):
    """A :class:`matplotlib.figure.Figure` on an Agg canvas of its own (``fig.canvas.draw()``
    and ``fig.canvas.buffer_rgba()`` give its pixels), outside pyplot: nothing keeps it alive
    but its owner, so it needs no closing. ``figure_kwargs`` go to ``Figure``.

    >>> fig = new_figure(figsize=(2, 1), dpi=50)
    >>> fig.canvas.draw()
    >>> fig.canvas.buffer_rgba().shape
    (50, 100, 4)
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**figure_kwargs)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig, path, **savefig_kwargs) -> Path:
    """Write ``fig`` to ``path`` (format from its suffix) atomically: through a temporary file
    beside it, renamed over it when complete (:func:`fftnav.files.atomic_path`), so a full disk
    or an error leaves no partial image under the real name. Returns ``path``."""
    from fftnav.files import atomic_path

    with atomic_path(path, keep_suffix=True) as tmp:
        fig.savefig(tmp, **savefig_kwargs)
    return Path(path)
