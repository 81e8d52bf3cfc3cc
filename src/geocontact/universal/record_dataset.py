"""The dataset of the design of record (``record``): one row per point, the normalised data the
fit needs, levels indexed by their position between the lowest peak and the top a/R.

Every quantity is dimensionless, in units of the analytic first yield (Fy, delta_y) of the point's
material, as in today's dataset (``dataset``). What differs: a level's force is no longer a
function of E/sigma_c alone (the levels are contact radii, their forces what the probe gave), so
each level carries its achieved force and contact radius, and the virgin curve is sampled
between 0.5 Fy and the row's own top force. Per point:

* ``fe_yield_ratio``, ``fully_plastic_ratio``: as today's;
* ``top_logf``: log10(F_top/Fy) of the top level (what the law's calibrated range ends at);
* ``virgin_logx_K``: log10(delta/delta_y) of the stitched virgin curve at F/Fy = 0.5
  (F_top / 0.5 Fy)^(K / 32), K = 0..32;
* per level L = 0..6 (position u = L/6 in log a/R): ``logf_L`` = log10(F/Fy) of its peak,
  ``contact_L`` = log10(a/R) the FE reached at the peak, ``logx_L``, ``residual_L``,
  ``work_L``, ``unloading_exponent_L``, ``reloading_exponent_L``, ``second_increment_L`` (as
  today's);
* the repeated history (``record.point_jobs``: 10 cycles to half the top force):
  ``cyclic_logf`` (log10 F/Fy of its peak), ``cyclic_logx`` (log10 delta_max/delta_y of cycle 1),
  ``cyclic_residual`` (cycle 1's delta_res/delta_max), ``cyclic_work`` (cycle 1's FE plastic
  dissipation over F delta_max), and per cycle N = 2..10 ``cyclic_residual_NN`` =
  log10 of its residual increment over cycle 1's and ``cyclic_dissipation_NN`` = log10 of its
  plastic dissipation over cycle 1's (``calibrate.cyclic_fit.cycle_table``'s ratios), each
  floored at ``RATIO_FLOOR`` (below it the FE resolves nothing: ``cyclic_fit.RESOLUTION``).

The cyclic extension of a material is then fitted exactly as ``geocontact calibrate`` fits it
(``cyclic_fit.analyse`` + ``with_cyclic``) to the cycles rebuilt from the interpolated columns;
its parameters at each point are in the point's entry of fits.json.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .dataset import format_points, parse_points
from .record import AXIS_NAMES, LEVELS

RECORD_FORMAT = "geocontact.universal-record/1"
VIRGIN_LOW = 0.5
VIRGIN_SAMPLES = 33
CYCLES = 10
RATIO_FLOOR = 1e-5  # cyclic_fit.RESOLUTION: a smaller residual increment is the FE's noise
LEVEL_FIELDS = ("logf", "contact", "logx", "residual", "work", "unloading_exponent",
                "reloading_exponent", "second_increment")
CYCLE_ONE = ("cyclic_logf", "cyclic_logx", "cyclic_residual", "cyclic_work")


def cycle_columns() -> list[str]:
    return [*CYCLE_ONE, *(f"cyclic_{name}_{n:02d}" for name in ("residual", "dissipation")
                          for n in range(2, CYCLES + 1))]


def columns() -> list[str]:
    cols = ["index", *AXIS_NAMES, "fe_yield_ratio", "fully_plastic_ratio", "top_logf"]
    cols += [f"virgin_logx_{k:02d}" for k in range(VIRGIN_SAMPLES)]
    cols += [f"{name}_{level}" for level in range(LEVELS) for name in LEVEL_FIELDS]
    return cols + cycle_columns()


def law_columns() -> list[str]:
    """The columns the law is rebuilt from (interpolated); the others are kept for the record."""
    cols = ["fe_yield_ratio", "top_logf"]
    cols += [f"virgin_logx_{k:02d}" for k in range(VIRGIN_SAMPLES)]
    cols += [f"{name}_{level}" for level in range(LEVELS) for name in LEVEL_FIELDS
             if name != "second_increment"]
    return cols + cycle_columns()


def virgin_force_grid(top_logf: float) -> np.ndarray:
    """F/Fy of the stored virgin samples: geometric from 0.5 to the row's top force."""
    return np.geomspace(VIRGIN_LOW, 10.0 ** float(top_logf), VIRGIN_SAMPLES)


def read_points(directory: str | Path) -> dict[str, np.ndarray]:
    path = Path(directory) / "points.csv"
    if not path.exists():
        return {c: np.empty(0) for c in columns()}
    return parse_points_text(path.read_text(), str(path))


def parse_points_text(text: str, where: str = "points.csv") -> dict[str, np.ndarray]:
    return parse_points(text, where, columns(), RECORD_FORMAT)


def format_rows(rows: list[dict[str, Any]]) -> str:
    return format_points(rows, columns())


# --- a row from a point's FE runs ------------------------------------------------------------
def point_row(point, runs, cyclic_result) -> dict[str, Any]:
    """The row of ``point`` from its extracted level runs (``calibrate.campaign.extract_run``)
    and the repeated history's FE result."""
    from ..calibrate.campaign import fe_fully_plastic, fe_yield
    from ..calibrate.fit import _power_exponent
    from ..grain.hertz import incipient_yield

    material = point.material()
    analytic = incipient_yield(material)
    fy, dy = analytic.force, analytic.approach
    runs = sorted(runs, key=lambda r: r.level.max_force)
    row: dict[str, Any] = {"index": point.index}
    row.update(zip(AXIS_NAMES, point.coordinates, strict=True))
    row["fe_yield_ratio"] = fe_yield(material, runs)["fe_force_N"] / fy
    fp = fe_fully_plastic(runs)["force_N"]
    row["fully_plastic_ratio"] = None if fp is None else fp / fy
    row["top_logf"] = float(np.log10(runs[-1].level.max_force / fy))
    row.update(virgin_samples(runs, fy, dy, row["top_logf"]))
    for level, run in enumerate(runs):
        lv = run.level
        row[f"logf_{level}"] = float(np.log10(lv.max_force / fy))
        row[f"contact_{level}"] = float(np.log10(peak_contact_radius(run) / material.radius))
        row[f"logx_{level}"] = float(np.log10(lv.max_approach / dy))
        row[f"residual_{level}"] = lv.residual_approach / lv.max_approach
        row[f"work_{level}"] = lv.plastic_work / lv.total_work
        for name, d, f in (("unloading", lv.unloading_approach, lv.unloading_force),
                           ("reloading", lv.reloading_approach, lv.reloading_force)):
            row[f"{name}_exponent_{level}"] = _power_exponent(
                d, f, lv.residual_approach, lv.max_approach, lv.max_force)[0]
        second = run.second_residual_approach
        row[f"second_increment_{level}"] = (None if second is None else
                                            (second - lv.residual_approach)
                                            / lv.residual_approach)
    row.update(cyclic_columns(cyclic_result.summary["cycles"], fy, dy))
    return row


def peak_contact_radius(run) -> float:
    """The FE's contact radius at a level run's first peak (curve.csv, the peak's row)."""
    curve = run.result.curve
    if "contact_radius_m" not in curve:
        raise InputError(f"record dataset: run {run.job.name()} records no contact radius")
    force = np.asarray(curve["force_N"])
    steps = run.result.summary["cycles"][0]["steps"]
    index = {int(s): i for i, s in enumerate(curve["step"])}
    first = slice(index[steps[0]], index[steps[1]] + 1)
    peak = first.start + int(np.argmax(force[first]))
    return float(curve["contact_radius_m"][peak])


def virgin_samples(runs, fy: float, dy: float, top_logf: float) -> dict[str, float]:
    """log10(delta/delta_y) of the stitched virgin curve on ``virgin_force_grid``; Hertz below
    the FE's first loaded step (``campaign.sample_virgin_curve``, as today's design samples)."""
    from .campaign import sample_virgin_curve

    values, _ = sample_virgin_curve(runs, fy, dy, virgin_force_grid(top_logf))
    return {f"virgin_logx_{k:02d}": float(v) for k, v in enumerate(values)}


def cyclic_columns(cycles: list[dict[str, Any]], fy: float, dy: float) -> dict[str, float]:
    """The repeated history's columns (module docstring) from the FE's ``summary["cycles"]``."""
    from ..calibrate.cyclic_fit import cycle_table

    rows = cycle_table(cycles)
    if len(rows) != CYCLES:
        raise InputError(f"record dataset: the repeated history has {len(rows)} cycles, "
                         f"expected {CYCLES}")
    first = rows[0]
    out = {"cyclic_logf": float(np.log10(first["max_force_N"] / fy)),
           "cyclic_logx": float(np.log10(first["max_approach_m"] / dy)),
           "cyclic_residual": first["residual_approach_m"] / first["max_approach_m"],
           "cyclic_work": first["plastic_work_J"] / (first["max_force_N"]
                                                     * first["max_approach_m"])}
    for row in rows[1:]:
        for name, key in (("residual", "residual_increment_ratio"),
                          ("dissipation", "plastic_work_ratio")):
            ratio = row[key] if row[key] is not None else 0.0
            out[f"cyclic_{name}_{row['cycle']:02d}"] = float(np.log10(max(ratio, RATIO_FLOOR)))
    return out


def rebuild_cycles(values: dict[str, float], fy: float, dy: float) -> list[dict[str, float]]:
    """FE-like cycles (``summary["cycles"]`` entries) of a material from normalised columns (a
    row, or the interpolated one): what ``cyclic_fit.analyse`` takes."""
    force = 10.0 ** values["cyclic_logf"] * fy
    dmax = 10.0 ** values["cyclic_logx"] * dy
    increment1 = min(max(values["cyclic_residual"], 0.0), 1.0) * dmax
    work1 = max(values["cyclic_work"], 0.0) * force * dmax
    cycles, residual = [], 0.0
    for n in range(1, CYCLES + 1):
        if n == 1:
            increment, work = increment1, work1
        else:
            increment = increment1 * _ratio(values[f"cyclic_residual_{n:02d}"])
            work = work1 * _ratio(values[f"cyclic_dissipation_{n:02d}"])
        residual += increment
        cycles.append({"max_force_N": force, "max_approach_m": dmax + residual - increment1,
                       "residual_approach_m": residual, "plastic_work_J": work,
                       "loop_work_J": work})
    return cycles


def _ratio(log10_value: float) -> float:
    """A stored ratio back; at (or interpolated below) the floor it is the FE's noise: 0."""
    value = 10.0 ** float(log10_value)
    return 0.0 if value <= RATIO_FLOOR * (1.0 + 1e-9) else value
