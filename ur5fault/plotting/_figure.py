"""Figures without pyplot: a :class:`matplotlib.figure.Figure` is made directly (no backend is chosen, no
global figure registry, nothing to close), or the caller's axes are drawn into.  A notebook shows a
returned figure; :func:`save` writes it (``Figure.savefig`` needs no backend either)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..errors import ParameterError
from ..util.checks import is_real, short
from ..util.io import write_figure_atomic


def check_kind(value: Any, kind: type | tuple[type, ...], where: str, what: str) -> None:
    """Refuse ``value`` unless it is a ``kind``: ``where = value must be what``, in one line."""
    if not isinstance(value, kind):
        raise ParameterError(f"{where} = {short(value)} must be {what}")


def check_ax(ax: Any, where: str) -> None:
    """An optional matplotlib Axes to draw into."""
    if ax is not None:
        check_kind(ax, Axes, where, "a matplotlib Axes to draw into, or None for a new figure")


def check_feature(feature: Any, where: str) -> None:
    """A feature name (its existence is checked against the table it is read from)."""
    if not isinstance(feature, str) or not feature:
        raise ParameterError(f"{where}: feature = {short(feature)} must be the name of a feature column "
                             "(e.g. 'tcp_dev_max_mm')")


def check_optional_number(value: Any, where: str) -> None:
    if value is not None and not is_real(value):
        raise ParameterError(f"{where} = {short(value)} must be a number, or None")


def check_folder(folder: Any, where: str) -> None:
    if not isinstance(folder, (str, os.PathLike)) or not str(folder).strip():
        raise ParameterError(f"{where} = {short(folder)} must be a folder path")


def figure_and_axes(ax: Axes | None, figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    """``ax`` and its figure, or a new figure of ``figsize`` [in] with one axes."""
    check_ax(ax, "ax")
    if ax is not None:
        return ax.figure, ax
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.add_subplot()


def save(figures: Mapping[str, Figure], folder: str | Path) -> list[Path]:
    """Write each figure as ``folder/<name>.png``; return the paths."""
    check_kind(figures, Mapping, "save: figures", "a mapping of file stem -> matplotlib Figure")
    for name, fig in figures.items():
        if not isinstance(name, str) or not name or Path(name).name != name:
            raise ParameterError(f"save: figure name {short(name)} must be a plain file stem (no folder)")
        check_kind(fig, Figure, f"save: figures[{name!r}]", "a matplotlib Figure")
    check_folder(folder, "save: folder")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fig in figures.items():
        path = folder / f"{name}.png"
        paths.append(write_figure_atomic(fig, path))
    return paths
