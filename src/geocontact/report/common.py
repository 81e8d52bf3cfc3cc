"""Shared pieces of the report sections: where figures go, reading a result's summary, log-axis
sampling."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

from ..errors import InputError
from ..figures import Figure, save_figure

FIGURES = "figures"
REPORT_HTML = "report.html"


def read_summary(directory: Path) -> dict | None:
    path = directory / "summary.json"
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: malformed JSON: {exc}") from None


def save_to_figures(fig, figures: Path, figure: Figure) -> Figure:
    """Save into DIR/figures/ and point the figure at it (paths relative to DIR)."""
    save_figure(fig, figures, figure)
    figure.image = f"{FIGURES}/{figure.name}.png"
    if figure.data:
        figure.data_file = f"{FIGURES}/{figure.name}.csv"
    return figure


def relative_dir(directory: Path, root: Path) -> str:
    rel = directory.relative_to(root).as_posix()
    return "" if rel == "." else rel + "/"


LOG_FLOOR = 1e-3
LOG_POINTS = 300


def positive(x, y) -> tuple[np.ndarray, np.ndarray]:
    """The points of a curve that a log-log axis can show (x > 0 and y > 0, finite): a line is
    never drawn through zero on a log axis."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    return x[keep], y[keep]


def readable_log_ticks(ax) -> None:
    """Tick labels of a log axis that spans little more than a decade: matplotlib labels every
    minor tick there (2, 3, ..., 9 x 10^n, overlapping); label 1, 2 and 5 x 10^n instead."""
    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        if axis.get_scale() != "log" or not 0 < lo < hi:
            continue
        if hi / lo <= 300.0:
            axis.set_major_locator(LogLocator(subs=(1.0,)))
            axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(FormatStrFormatter("%g"))
        else:
            axis.set_minor_formatter(NullFormatter())


def toward(start: float, end: float, points: int, floor: float) -> np.ndarray:
    """From ``start`` to ``end``, dense on a log scale of the distance to ``end``
    (down to ``floor`` of the span): an unloading branch that vanishes at the residual
    approach as a power of the distance is then resolved to its end."""
    span = start - end
    return end + span * np.geomspace(1.0, floor, points)
