"""The universal law's dataset: one row per campaign point, the normalised data the fit needs.

Every quantity is dimensionless, in units of the analytic first yield of the point's material
(``geocontact.grain.hertz.incipient_yield``: Fy, delta_y), so that a row applies to any E and radius
(docs/model.md §10). Per point:

* ``fe_yield_ratio``: the FE first-yield force over the analytic Fy (the law's yield point is the
  Hertz approach of the FE force, as ``calibrate.campaign.fe_yield`` makes it);
* ``virgin_logx_K``: log10(delta/delta_y) of the virgin loading curve (stitched from the levels'
  loading segments as ``calibrate.campaign.virgin_curve`` does) at the fixed forces
  F/Fy = ``virgin_force_grid(s)[K]`` (s = log10(E/sigma_c));
* per level L (peaks ``design.force_levels(s)[L]`` x Fy): ``logx_L`` = log10(delta_max/delta_y),
  ``residual_L`` = delta_res/delta_max, ``work_L`` = Wp/Wtotal (loop work over the work done on
  the virgin loading, as ``calibrate.campaign.extract_run``), ``unloading_exponent_L`` and
  ``reloading_exponent_L`` (``calibrate.fit._power_exponent`` on the FE curves, the fit's own
  reduction of a curve), ``second_increment_L`` (residual increment of the reload over
  delta_res, the shakedown indicator);
* ``fully_plastic_ratio``: the FE's fully plastic onset force over Fy (empty if not reached).

The dataset is ``geocontact/data/universal/points.csv`` + ``provenance.json`` (inputs, mesh,
FE source hash, version, wall time per run, per point).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .design import AXIS_NAMES, LEVELS, top_force_over_yield

DATASET_FORMAT = "geocontact.universal/1"
# F/Fy of the stored virgin curve: geometric from below first yield (Hertz, where the FE's own
# yield force may sit a few % from the analytic one) to the point's top level, the same number
# of samples at every point (8 to 12 per decade), so sample K is at the same relative place.
VIRGIN_LOW = 0.5
VIRGIN_SAMPLES = 33


def virgin_force_grid(log10_modulus_over_strength: float) -> np.ndarray:
    return np.geomspace(VIRGIN_LOW, top_force_over_yield(log10_modulus_over_strength),
                        VIRGIN_SAMPLES)


LEVEL_FIELDS = ("logx", "residual", "work", "unloading_exponent", "reloading_exponent",
                "second_increment")


def columns() -> list[str]:
    """Every column of points.csv, in order."""
    cols = ["index", *AXIS_NAMES, "fe_yield_ratio", "fully_plastic_ratio"]
    cols += [f"virgin_logx_{k:02d}" for k in range(VIRGIN_SAMPLES)]
    cols += [f"{name}_{level}" for level in range(LEVELS) for name in LEVEL_FIELDS]
    return cols


# Quantities the law is rebuilt from (interpolated over material space); the others are kept
# for the record and the similarity study.
def law_columns() -> list[str]:
    cols = ["fe_yield_ratio"]
    cols += [f"virgin_logx_{k:02d}" for k in range(VIRGIN_SAMPLES)]
    cols += [f"{name}_{level}" for level in range(LEVELS)
             for name in ("logx", "residual", "work", "unloading_exponent",
                          "reloading_exponent")]
    return cols


def default_directory() -> Path:
    return Path(str(resources.files("geocontact") / "data" / "universal"))


def read_points(directory: str | Path | None = None) -> dict[str, np.ndarray]:
    """points.csv as columns (float arrays; empty cells NaN), sorted by index."""
    path = Path(directory or default_directory()) / "points.csv"
    if not path.exists():
        return {c: np.empty(0) for c in columns()}
    return parse_points(path.read_text(), str(path))


def parse_points(text: str, where: str = "points.csv", expected: list[str] | None = None,
                 layout: str = DATASET_FORMAT) -> dict[str, np.ndarray]:
    """Columns of a points.csv text; ``expected``/``layout``: another design version's
    columns and format name (default today's)."""
    rows = list(csv.DictReader(io.StringIO(text)))
    expected = columns() if expected is None else expected
    if rows and list(rows[0].keys()) != expected:
        raise InputError(f"{where}: columns differ from this version's dataset layout "
                         f"({layout}); rebuild it with the campaign command")
    data = {c: np.array([float(r[c]) if r[c] != "" else np.nan for r in rows], dtype=float)
            for c in expected}
    order = np.argsort(data["index"], kind="stable")
    return {c: v[order] for c, v in data.items()}


def format_points(rows: list[dict[str, Any]], cols: list[str] | None = None) -> str:
    """CSV text of ``rows`` (dicts keyed by ``cols``, default ``columns()``), 10 significant
    digits, by index."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    cols = columns() if cols is None else cols
    writer.writerow(cols)
    for row in sorted(rows, key=lambda r: int(r["index"])):
        writer.writerow([_cell(row.get(c)) for c in cols])
    return out.getvalue()


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    value = float(value)
    if not np.isfinite(value):
        return ""
    return f"{value:.10g}"


def rows_of(data: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    n = data["index"].size
    return [{c: (int(data[c][i]) if c == "index" else data[c][i]) for c in data}
            for i in range(n)]


def dataset_hash(directory: str | Path | None = None) -> str:
    """SHA-256 of points.csv (the dataset's version for a law built from it)."""
    path = Path(directory or default_directory()) / "points.csv"
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else ""


def read_provenance(directory: str | Path | None = None) -> dict[str, Any]:
    path = Path(directory or default_directory()) / "provenance.json"
    if not path.exists():
        return {"format": DATASET_FORMAT, "points": {}}
    return json.loads(path.read_text())
