"""Figures for reports, drawn without touching the user's matplotlib state.

Library code must not switch the global backend (``matplotlib.use``) nor keep figures
in pyplot's registry: a notebook or GUI user would lose theirs.  Figures here are
``matplotlib.figure.Figure`` objects on their own Agg canvas, saved atomically.
matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

from pathlib import Path

from .io import atomic_path

#: Resolution of saved figures [dots per inch]: legible at the saved size.
DPI = 110


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **subplots):
    """(figure, axes) on a private Agg canvas; ``subplots`` go to ``Figure.subplots``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **subplots)


def save_figure(fig, path: str | Path, dpi: int = DPI) -> Path:
    """Write ``fig`` as PNG atomically (no half-written image after an interruption)."""
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    return Path(path)


__all__ = ["new_figure", "save_figure", "DPI"]
