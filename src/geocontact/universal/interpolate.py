"""The universal law: the dataset's normalised quantities interpolated over material space,
turned back into FE-like data for a material and fitted by the project's own fit.

For a material (any E, radius; beta, nu, m and E/sigma_c inside the campaign's box):

1. every law quantity of the dataset (``dataset.law_columns``) is interpolated at the
   material's coordinates (scipy ``RBFInterpolator`` on the unit box, a polynomial of degree 1
   plus a radial kernel; the kernel of each quantity is the one with the smallest
   leave-one-out error among ``KERNELS``, chosen from the data, no hand-set number);
2. the normalised data are made dimensional with the material's analytic first yield
   (``hertz.incipient_yield``: Fy, delta_y): the virgin curve, and per level the peak, the
   residual approach, the work ratio and power-law unloading and reloading curves with the
   interpolated exponents (``calibrate.fit`` reduces a curve to exactly that exponent);
3. ``calibrate.fit.fit_law`` fits the law to them: the same code path as ``geocontact
   calibrate`` (``fit_runs``) and the lab-test fit.

The error expected at the material is the leave-one-out error of the nodes near it (inverse
distance weights in the unit box), per quantity group.

    params = universal_params(material)            # LawParams, provenance says where from
"""

from __future__ import annotations

import functools
import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, run_reporting_errors
from ..files import write_json_atomic
from ..grain.hertz import hertz_coefficient, incipient_yield
from ..grain.material import Material
from .dataset import (
    LEVEL_FIELDS,
    VIRGIN_SAMPLES,
    default_directory,
    law_columns,
    read_points,
    virgin_force_grid,
)
from .design import (
    AXIS_NAMES,
    coordinates_of,
    force_levels,
    material_at,
    outside_range,
    unit,
)

KERNELS = ("thin_plate_spline", "cubic", "linear")
# The FE's first-yield force over the analytic one is 0.95-1.01 over the box except at the
# corner beta = 55 deg, nu = 0.15 (1.8-2.9: there first yield is at the contact edge, which the
# FE resolves late, docs/universal.md); a smooth kernel spreads that jump over the whole space
# (law yield 0.81-1.29 x the FE's at the acceptance materials), the linear kernel keeps it local.
LOCAL_KERNEL = "linear"
LOCAL_COLUMNS = ("fe_yield_ratio",)
MIN_POINTS = 6  # a degree-1 polynomial in 4 coordinates needs 5 nodes; one more for the LOO
# Samples of each rebuilt unloading/reloading curve (the fit takes 2-98 % of the peak force).
CURVE_SAMPLES = 41
# Warm starts of the saturating fits: those of the nearest campaign points (fits.json).
WARM_STARTS = 2
# Quantity groups reported as the expected error at a material.
GROUPS = {
    "fe_yield_ratio": ("fe_yield_ratio",),
    "virgin_log10_approach": ("virgin_logx_",),
    "level_log10_approach": ("logx_",),
    "residual_ratio": ("residual_",),
    "plastic_work_ratio": ("work_",),
    "unloading_exponent": ("unloading_exponent_",),
    "reloading_exponent": ("reloading_exponent_",),
}


@dataclass
class Surfaces:
    """The interpolating surfaces of one dataset and their leave-one-out errors."""

    columns: list[str]
    nodes: np.ndarray  # unit coordinates, (n, 4)
    values: np.ndarray  # (n, q)
    kernels: list[str]  # per column
    loo_error: np.ndarray  # (n, q): |LOO prediction - value| at each node
    interpolators: dict[str, Any]
    dataset_sha256: str
    slope: float  # of the approach baseline (``baseline``)
    data: dict[str, np.ndarray] | None = None  # the dataset's columns the surfaces were built on

    def __call__(self, coordinates) -> dict[str, float]:
        u = np.atleast_2d(unit(coordinates))
        out = baseline(self.columns, float(np.asarray(coordinates)[3]), self.slope)
        for _kernel, (rbf, index) in self.interpolators.items():
            out[index] += rbf(u)[0]
        return dict(zip(self.columns, out, strict=True))

    def expected_error(self, coordinates) -> dict[str, float]:
        """Leave-one-out error expected at ``coordinates``: per group, the largest over its
        columns of the inverse-square-distance mean of the nodes' LOO errors."""
        u = unit(coordinates)
        d2 = np.sum((self.nodes - u) ** 2, axis=1)
        if np.any(d2 < 1e-24):
            w = (d2 < 1e-24).astype(float)
        else:
            w = 1.0 / d2
        w /= w.sum()
        per_column = w @ self.loo_error
        out = {}
        for group, prefixes in GROUPS.items():
            index = [i for i, c in enumerate(self.columns)
                     if any(c == p or (p.endswith("_") and c.startswith(p)) for p in prefixes)]
            out[group] = float(np.max(per_column[index]))
        return out

    def loo_summary(self) -> dict[str, dict[str, float]]:
        """Per group: RMS and max LOO error over nodes and columns, and the kernels used."""
        out = {}
        for group, prefixes in GROUPS.items():
            index = [i for i, c in enumerate(self.columns)
                     if any(c == p or (p.endswith("_") and c.startswith(p)) for p in prefixes)]
            e = self.loo_error[:, index]
            out[group] = {"rms": float(np.sqrt(np.mean(e**2))), "max": float(np.max(e)),
                          "kernels": sorted({self.kernels[i] for i in index})}
        return out


# The approach columns are interpolated about a baseline in log10(F/Fy): a point's samples sit
# at forces that move with E/sigma_c (the levels and the virgin grid end at the top level,
# 140 x 10^(s - 2) Fy), so log10 x at sample K changes by a decade and more along s although
# at a fixed F/Fy it hardly does (similarity). The baseline is Hertz below Fy (slope 2/3) and a
# power law above, its slope fitted to every node's samples (least squares); the RBF then
# carries only the deviation from it. Exact at the nodes like any other column.
TRANSFORM = ("yield ratio linear kernel; approach about the baseline "
             "log10 x = 2/3 min(l, 0) + k max(l, 0), l = log10 F/Fy")


def force_positions(columns: list[str], s: float) -> np.ndarray:
    """log10(F/Fy) of each approach column's sample at log10(E/sigma_c) = s (NaN: others)."""
    virgin = np.log10(virgin_force_grid(s))
    levels = np.log10(force_levels(s))
    out = np.full(len(columns), np.nan)
    for j, c in enumerate(columns):
        if c.startswith("virgin_logx_"):
            out[j] = virgin[int(c.rpartition("_")[2])]
        elif c.startswith("logx_"):
            out[j] = levels[int(c.rpartition("_")[2])]
    return out


def baseline(columns: list[str], s: float, slope: float) -> np.ndarray:
    lf = force_positions(columns, s)
    out = (2.0 / 3.0) * np.minimum(lf, 0.0) + slope * np.maximum(lf, 0.0)
    return np.where(np.isfinite(lf), out, 0.0)


def baseline_slope(columns: list[str], values: np.ndarray, s: np.ndarray) -> float:
    """k of the baseline: least squares of log10 x - 2/3 min(l, 0) = k max(l, 0) over every
    approach sample above Fy of every node."""
    lf = np.array([force_positions(columns, float(v)) for v in s])
    above = np.isfinite(lf) & (lf > 0.0)
    return float(np.sum(lf[above] * values[above]) / np.sum(lf[above] ** 2))


def _rbf(nodes, values, kernel, degree: int = 1):
    from scipy.interpolate import RBFInterpolator

    return RBFInterpolator(nodes, values, kernel=kernel, degree=degree)


def _loo(nodes: np.ndarray, values: np.ndarray, kernel: str, degree: int = 1) -> np.ndarray:
    """|prediction - value| at each node from the surface of the others, all columns."""
    n = nodes.shape[0]
    error = np.empty_like(values)
    for i in range(n):
        keep = np.arange(n) != i
        try:
            rbf = _rbf(nodes[keep], values[keep], kernel, degree)
        except np.linalg.LinAlgError:  # the other nodes do not span the box (too few)
            error[i] = np.inf
            continue
        error[i] = np.abs(rbf(nodes[i:i + 1])[0] - values[i])
    return error


def build_surfaces(data: dict[str, np.ndarray], sha256: str = "",
                   loo: dict[str, Any] | None = None) -> Surfaces:
    """The surfaces of a dataset (``dataset.read_points``); kernels chosen per column by LOO.

    ``loo``: the kernels and LOO errors ``prepare`` stored for this dataset (fits.json), used
    when their dataset hash is ``sha256`` instead of recomputing them."""
    n = data["index"].size
    if n < MIN_POINTS:
        raise InputError(f"universal law: the dataset has {n} points; at least {MIN_POINTS} "
                         "are needed (run the campaign: python -m geocontact.universal.campaign)")
    columns = law_columns()
    nodes = unit(np.column_stack([data[name] for name in AXIS_NAMES]))
    values = np.column_stack([data[c] for c in columns])
    if not np.all(np.isfinite(values)):
        bad = [c for c in columns if not np.all(np.isfinite(data[c]))]
        raise InputError(f"universal law: the dataset has empty values in {', '.join(bad[:3])}")
    s = data[AXIS_NAMES[3]]
    slope = baseline_slope(columns, values, s)
    shifted = values - np.array([baseline(columns, float(v), slope) for v in s])
    if loo and sha256 and loo.get("dataset_sha256") == sha256 \
            and loo.get("columns") == columns and loo.get("transform") == TRANSFORM:
        kernels = list(loo["kernels"])
        error = np.array(loo["loo_error"], dtype=float)
        if error.shape != values.shape:
            raise InputError("universal law: fits.json does not match points.csv; rerun "
                             "python -m geocontact.universal.interpolate --prepare")
        table = _assemble(columns, nodes, values, shifted, kernels, error, sha256, slope)
        table.data = data
        return table
    errors = {k: _loo(nodes, shifted, k) for k in KERNELS}
    # per column: the kernel with the smallest RMS LOO error
    rms = np.array([np.sqrt(np.mean(errors[k] ** 2, axis=0)) for k in KERNELS])
    # a kernel whose system is singular for some subset (e.g. the thin-plate spline on nodes
    # at equal mutual distances) is not used
    rms[~np.all(np.isfinite(rms), axis=1)] = np.inf
    if not np.any(np.isfinite(rms)):
        raise InputError(f"universal law: the dataset's {n} points do not span the four "
                         "coordinates well enough for a leave-one-out check; run more of the "
                         "campaign (python -m geocontact.universal.campaign)")
    best = np.argmin(rms, axis=0)
    kernels = [LOCAL_KERNEL if c in LOCAL_COLUMNS else KERNELS[b]
               for c, b in zip(columns, best, strict=True)]
    errors.setdefault(LOCAL_KERNEL, _loo(nodes, shifted, LOCAL_KERNEL))
    error = np.column_stack([errors[kernels[j]][:, j] for j in range(len(columns))])
    table = _assemble(columns, nodes, values, shifted, kernels, error, sha256, slope)
    table.data = data
    return table


def _assemble(columns, nodes, values, shifted, kernels, error, sha256, slope) -> Surfaces:
    interpolators = {}
    for kernel in KERNELS:
        index = np.array([j for j, k in enumerate(kernels) if k == kernel], dtype=int)
        if index.size:
            interpolators[kernel] = (_rbf(nodes, shifted[:, index], kernel), index)
    return Surfaces(columns, nodes, values, kernels, error, interpolators, sha256, slope)


@functools.lru_cache(maxsize=4)
def _surfaces_of(directory: str, sha256: str, text: bytes) -> Surfaces:
    from .dataset import parse_points

    data = parse_points(text.decode(), f"{directory}/points.csv") if text else read_points(
        directory)
    return build_surfaces(data, sha256, read_loo(directory))


def read_loo(directory: str | Path | None = None) -> dict[str, Any] | None:
    path = Path(directory or default_directory()) / FITS_FILE
    if not path.exists():
        return None
    return json.loads(path.read_text()).get("surfaces")


def surfaces(directory: str | Path | None = None) -> Surfaces:
    """The surfaces of the dataset in ``directory`` (default: the shipped one), cached by the
    dataset's hash."""
    import hashlib

    directory = str(Path(directory or default_directory()))
    path = Path(directory) / "points.csv"
    text = path.read_bytes() if path.exists() else b""  # once: hash and rows agree
    return _surfaces_of(directory, hashlib.sha256(text).hexdigest() if text else "", text)


def normalised_data(values: dict[str, float], s: float) -> dict[str, Any]:
    """The interpolated quantities as curves and levels in units of the analytic Fy, dy."""
    force = virgin_force_grid(s)
    logx = np.array([values[f"virgin_logx_{k:02d}"] for k in range(VIRGIN_SAMPLES)])
    levels = []
    for level, peak in enumerate(force_levels(s)):
        levels.append({"force": float(peak), **{
            name: float(values[f"{name}_{level}"]) for name in LEVEL_FIELDS
            if name != "second_increment"}})
    return {"virgin_force": force, "virgin_approach": 10.0 ** np.maximum.accumulate(logx),
            "levels": levels, "fe_yield_ratio": float(values["fe_yield_ratio"])}


def rebuild(material: Material, values: dict[str, float]):
    """FE-like data of ``material`` from normalised quantities (a row of the dataset, or the
    interpolated one): yield approach, virgin curve and per-level ``calibrate.fit.LevelData``."""
    return rebuild_from(material, normalised_data(values, float(coordinates_of(material)[3])))


def rebuild_from(material: Material, data: dict[str, Any]):
    """``rebuild`` of normalised data (``normalised_data``'s dict: virgin force and approach in
    Fy and delta_y, levels with their force in Fy, the yield ratio), any design version's."""
    from ..calibrate.fit import LevelData

    analytic = incipient_yield(material)
    fy, dy = analytic.force, analytic.approach
    kh = hertz_coefficient(material)
    yield_approach = (data["fe_yield_ratio"] * fy / kh) ** (2.0 / 3.0)
    d_virgin = data["virgin_approach"] * dy
    f_virgin = data["virgin_force"] * fy
    # the virgin curve from zero (its first sample is elastic, below first yield)
    d_all = np.concatenate([[0.0], d_virgin])
    f_all = np.concatenate([[0.0], f_virgin])
    levels = []
    t = np.linspace(0.0, 1.0, CURVE_SAMPLES)
    # Levels within 20 % of the law's (FE) first yield are elastic for the law (where the
    # FE's first yield lags the analytic one, steep friction angles and low nu, the FE shows no
    # residual approach there): left out, as `calibrate` refuses such peaks (check_peaks).
    plastic = [lv for lv in data["levels"] if lv["force"] > 1.2 * data["fe_yield_ratio"]]
    data["levels_used"] = plastic if len(plastic) >= 3 else data["levels"][-3:]
    for lv in data["levels_used"]:
        peak = lv["force"] * fy
        dmax = 10.0 ** lv["logx"] * dy
        dres = min(max(lv["residual"], 0.0), 1.0 - 1e-9) * dmax
        upto = d_all < dmax
        total = float(np.trapezoid(np.append(f_all[upto], peak), np.append(d_all[upto], dmax)))
        approach = dres + (dmax - dres) * t
        levels.append(LevelData(
            max_approach=dmax, max_force=peak, residual_approach=dres,
            plastic_work=min(max(lv["work"], 0.0), 1.0 - 1e-9) * total, total_work=total,
            unloading_approach=approach[::-1].copy(),
            unloading_force=(peak * t ** lv["unloading_exponent"])[::-1].copy(),
            reloading_approach=approach.copy(),
            reloading_force=peak * t ** lv["reloading_exponent"]))
    return yield_approach, d_virgin, f_virgin, levels, data, analytic


FITS_FILE = "fits.json"


def row_key(data: dict[str, np.ndarray], i: int) -> str:
    """Hash of row i's law columns and coordinates (a node's fit is reused while it holds)."""
    import hashlib

    cells = [f"{data[c][i]:.10g}" for c in (*AXIS_NAMES, *law_columns())]
    return hashlib.sha256(",".join(cells).encode()).hexdigest()[:16]


def node_fit(data: dict[str, np.ndarray], i: int) -> dict[str, list[float]]:
    """The saturating fits of node i's own data (full multi-start ``fit_law``)."""
    from ..calibrate.fit import fit_law

    coords = [float(data[n][i]) for n in AXIS_NAMES]
    material = material_at(coords)
    values = {c: float(data[c][i]) for c in law_columns()}
    yield_approach, d_virgin, f_virgin, levels, _, _ = rebuild(material, values)
    p = fit_law(material, yield_approach, d_virgin, f_virgin, levels)
    return {"residual": list(p.residual_closed_form("the universal law's warm starts")),
            "plastic_work": [p.plastic_work_limit, p.plastic_work_power,
                             p.plastic_work_transition, p.plastic_work_log_power]}


def read_fits(directory: str | Path | None = None) -> dict[str, Any]:
    path = Path(directory or default_directory()) / FITS_FILE
    if not path.exists():
        return {}
    return json.loads(path.read_text()).get("nodes", {})


def prepare(directory: str | Path | None = None, progress: bool = True,
            refit: bool = False) -> int:
    """Write fits.json: every node's saturating fits (the warm starts of ``universal_params``).
    Nodes whose row is unchanged keep their entry (unless ``refit``, or it records a failed
    fit); returns the number fitted now."""
    import hashlib

    from .dataset import parse_points

    directory = Path(directory or default_directory())
    text = (directory / "points.csv").read_bytes()  # once: the campaign may append meanwhile
    data = parse_points(text.decode(), str(directory / "points.csv"))
    old = read_fits(directory)
    nodes, fitted = {}, 0
    for i in range(data["index"].size):
        key = row_key(data, i)
        index = str(int(data["index"][i]))
        if not refit and index in old and old[index].get("row") == key \
                and "error" not in old[index]:
            nodes[index] = old[index]
            continue
        try:
            nodes[index] = {"row": key, **node_fit(data, i)}
        except InputError as exc:  # recorded; such a node gives no warm start
            nodes[index] = {"row": key, "error": str(exc)}
        fitted += 1
        if progress:
            print(f"universal: node {index} fitted", file=sys.stderr)
    sha256 = hashlib.sha256(text).hexdigest()
    table = build_surfaces(data, sha256)
    write_json_atomic(directory / FITS_FILE, {
        "format": "geocontact.universal-fits/1",
        "what": "per campaign point, the saturating fits (limit, power, transition, log power) "
                "of its own data by calibrate.fit.fit_law (30-start grid): the warm starts of "
                "the universal law's fit at a material near it",
        "command": "python -m geocontact.universal.interpolate --prepare",
        "nodes": nodes,
        "surfaces": {"dataset_sha256": sha256, "transform": TRANSFORM,
                     "baseline_slope": table.slope, "columns": table.columns,
                     "kernels": table.kernels, "loo_error": table.loo_error}})
    return fitted


def warm_starts(data: dict[str, np.ndarray], fits: dict[str, Any], u: np.ndarray,
                count: int = WARM_STARTS) -> dict[str, list] | None:
    """The saturating fits of the ``count`` nodes nearest to ``u`` (unit box) whose entry in
    fits.json matches their row; None if there is none (then the full grid is used)."""
    nodes = unit(np.column_stack([data[n] for n in AXIS_NAMES]))
    order = np.argsort(np.sum((nodes - u) ** 2, axis=1))
    chosen = []
    for i in order:
        entry = fits.get(str(int(data["index"][i])))
        if entry is not None and "residual" in entry and entry.get("row") == row_key(data, i):
            chosen.append(entry)
        if len(chosen) == count:
            break
    if not chosen:
        return None
    return {"residual": [e["residual"] for e in chosen],
            "plastic_work": [e["plastic_work"] for e in chosen]}


def universal_params(material: Material, *, extrapolate: bool = False,
                     directory: str | Path | None = None):
    """The universal law's LawParams for ``material`` (see the module's docstring)."""

    problems = outside_range(material)
    if problems and not extrapolate:
        raise InputError(problems[0] + " (pass --extrapolate / extrapolate=True to accept "
                                       "it with a larger error)")
    table = surfaces(directory)
    coords = coordinates_of(material)
    values = table(coords)
    yield_approach, d_virgin, f_virgin, levels, data, analytic = rebuild(material, values)
    starts = warm_starts(table.data, read_fits(directory), unit(coords))
    expected = table.expected_error(coords)
    provenance = {
        "source": "universal law (geocontact params): the FE campaign's normalised data "
                  "interpolated over material space, fitted by calibrate.fit.fit_law",
        "universal": {
            "dataset_sha256": table.dataset_sha256,
            "points": int(table.nodes.shape[0]),
            "coordinates": dict(zip(AXIS_NAMES, (float(c) for c in coords), strict=True)),
            "inside_range": not problems,
            "outside_range": problems,
            "expected_error_loo": expected,
            "expected_error_note": (
                "leave-one-out interpolation error of the dataset's nodes near this material "
                "(absolute, in each quantity's unit: log10 approach, ratios, exponents)"
                + ("; the material is OUTSIDE the campaign's range: the interpolation "
                   "extrapolates and the real error can be larger" if problems else "")),
            "fe_mesh": "coarse",
            "levels_force_over_yield": [lv["force"] for lv in data["levels_used"]],
            "saturating_fit_start": ("the fits of the nearest campaign points (fits.json)"
                                     if starts else "the fit's full start grid"),
        },
    }
    try:
        params = _fit_within_energy(material, yield_approach, d_virgin, f_virgin, levels,
                                    provenance, starts)
    except InputError as exc:
        if not problems:
            raise
        raise InputError(f"{problems[0]}; extrapolated that far the data give no valid law "
                         f"({exc})") from None
    params = _with_valid_depth(params)
    return replace(params, label="universal", yield_extra={
        "analytic_force_N": analytic.force, "analytic_approach_m": analytic.approach,
        "fe_over_analytic_force": data["fe_yield_ratio"],
        "source": "universal law: the FE first-yield force over the analytic one, "
                  "interpolated; approach = Hertz approach of that force"})


def _fit_within_energy(material, yield_approach, d_virgin, f_virgin, levels, provenance,
                       starts):
    """``fit_law``; when the fitted law would create energy (the parameter check refuses it),
    the top level is left out and the virgin curve cut at the next one, and the fit repeated
    (at least 3 levels). Where it happens: near E/sigma_c = 100 the FE's virgin curve stiffens
    over its top level (the contact reaches a few tenths of R, finite size) more than the
    law's power-law regimes can follow without giving back more than was put in. The
    calibrated range in ``provenance.universal.valid_depth`` says where the law stops."""
    from ..calibrate.fit import fit_law

    levels = list(levels)
    while True:
        try:
            return fit_law(material, yield_approach, d_virgin, f_virgin, levels,
                           provenance=provenance, starts=starts)
        except InputError as exc:
            if "creates energy" not in str(exc) or len(levels) <= 3:
                raise
            dropped = levels.pop()
            keep = f_virgin <= levels[-1].max_force * (1.0 + 1e-9)
            d_virgin, f_virgin = d_virgin[keep], f_virgin[keep]
            provenance["universal"].setdefault("levels_left_out", []).append({
                "force_N": dropped.max_force,
                "reason": f"the law fitted with it creates energy ({exc})"})


def _with_valid_depth(params):
    """The calibrated range of a universal law (``fit_law``'s: its top level, after any level
    left out) said as the campaign's: ``provenance.universal.valid_depth`` and the range's
    source. Beyond it the law extrapolates, and ``geocontact law`` and the API say so."""
    u = params.provenance["universal"]
    kept = len(u["levels_force_over_yield"]) - len(u.get("levels_left_out", []))
    top = u["levels_force_over_yield"][kept - 1]
    u["valid_depth"] = {
        "levels_force_over_yield": [u["levels_force_over_yield"][0], top],
        "max_depth": params.calibrated_depth,
        "max_force_N": params.calibrated_range["max_force_N"],
        "note": "the campaign's levels at this material (in the analytic Fy; higher levels "
                "left out: levels_left_out); beyond max_depth the law extrapolates "
                "(calibrated_range)"}
    extra = {**params.calibrated_range_extra,
             "source": f"the campaign's top level at this material, {top:.4g} Fy "
                       "(interpolated; provenance.universal.valid_depth)"}
    return replace(params, calibrated_range_extra=extra)


def main_summary(params) -> dict[str, Any]:
    u = params.provenance["universal"]
    return {"label": params.label, "yield_force_N": params.yield_force,
            "yield_approach_m": params.yield_approach, "points": u["points"],
            "inside_range": u["inside_range"], "expected_error_loo": u["expected_error_loo"],
            "dataset_sha256": u["dataset_sha256"]}


def main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m geocontact.universal.interpolate",
        description="Prepare the universal law from its dataset: --prepare writes fits.json "
                    "(every node's saturating fits); --loo prints the leave-one-out errors.")
    parser.add_argument("--dataset", default=None, help="dataset folder (default: shipped)")
    parser.add_argument("--prepare", action="store_true")
    parser.add_argument("--refit", action="store_true",
                        help="with --prepare: refit every node (after a change of the fit)")
    parser.add_argument("--loo", action="store_true")
    args = parser.parse_args(argv)

    def run() -> int:
        if args.prepare:
            print(f"fitted {prepare(args.dataset, refit=args.refit)} nodes")
        if args.loo:
            print(json.dumps(surfaces(args.dataset).loo_summary(), indent=2))
        return 0

    return run_reporting_errors(run)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
