"""Figures without pyplot: the one place the package makes and saves plots.

Agg canvases only, so a plot never changes the backend of the user's session.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from precise_impact.io.atomic import atomic_write

__all__ = ["figure", "new_figure", "save_figure"]


def figure(figsize: tuple[float, float] = (7.0, 4.5), layout: str | None = None):
    """An empty :class:`~matplotlib.figure.Figure` with an Agg canvas of its own (no pyplot).

    Parameters
    ----------
    figsize : (float, float), default ``(7.0, 4.5)``
        Size in inches.
    layout : str or None, default ``None``
        Matplotlib layout engine (``'constrained'``, ``'tight'`` or ``None``).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def new_figure(
    nrows: int = 1,
    ncols: int = 1,
    figsize: tuple[float, float] = (7.0, 4.5),
    layout: str | None = "constrained",
    **subplots_kw: Any,
):
    """A new figure and its axes, drawn by an Agg canvas of its own.

    Parameters
    ----------
    nrows, ncols : int, default 1
        Grid of axes.
    figsize : (float, float), default ``(7.0, 4.5)``
        Size in inches.
    layout : str or None, default ``'constrained'``
        Matplotlib layout engine.
    **subplots_kw
        Passed to :meth:`matplotlib.figure.Figure.subplots` (``sharex``, ``gridspec_kw`` ...).

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : numpy.ndarray of Axes, shape ``(nrows, ncols)``
    """
    fig = figure(figsize, layout)
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplots_kw)
    return fig, axes


def save_figure(fig, path: str | os.PathLike, fmt: str | None = None, dpi: int = 150) -> Path:
    """Save ``fig`` to ``path`` atomically (format from the suffix unless ``fmt``).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = Path(path)
    fmt = fmt or path.suffix.lstrip(".").lower() or "png"
    atomic_write(path, lambda fh: fig.savefig(fh, format=fmt, dpi=dpi), binary=True)
    return path
