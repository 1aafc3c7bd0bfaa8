"""Figures without pyplot: a :class:`matplotlib.figure.Figure` is made directly (no backend is chosen, no
global figure registry, nothing to close), or the caller's axes are drawn into.  A notebook shows a
returned figure; :func:`save` writes it (``Figure.savefig`` needs no backend either)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..util.io import write_figure_atomic


def figure_and_axes(ax: Axes | None, figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    """``ax`` and its figure, or a new figure of ``figsize`` [in] with one axes."""
    if ax is not None:
        return ax.figure, ax
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.add_subplot()


def save(figures: Mapping[str, Figure], folder: str | Path) -> list[Path]:
    """Write each figure as ``folder/<name>.png``; return the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fig in figures.items():
        path = folder / f"{name}.png"
        paths.append(write_figure_atomic(fig, path))
    return paths
