"""Figure records shared by every module that draws: a figure's PNG and its data as CSV beside
it. Below calibrate in the import flow (material -> hertz -> fem -> calibrate -> law -> analyses
-> report -> cli), so calibration's acceptance figures and the report's sections use the same
record without calibrate importing the report (which re-exports both names)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .files import atomic_path, write_csv  # noqa: E402


@dataclass
class Figure:
    name: str
    title: str
    caption: str
    data: dict = field(default_factory=dict)  # column name -> array, written as NAME.csv
    image: str = ""  # path of an existing PNG relative to the report folder (default NAME.png)
    data_file: str = ""  # path of an existing CSV holding the figure's data, if not ``data``


def save_figure(fig, directory: Path, figure: Figure) -> None:
    """Write the matplotlib figure ``fig`` as ``directory/NAME.png`` (atomically) and its data as
    ``NAME.csv``, then close it."""
    directory.mkdir(parents=True, exist_ok=True)
    with atomic_path(directory / f"{figure.name}.png") as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    if figure.data:
        write_csv(directory / f"{figure.name}.csv", figure.data)
