"""Similarity of the contact in material space (docs/model.md §10, issue 12; docs/similarity.md).

In units of the first-yield force Fy and approach delta_y the contact of two identical
Drucker-Prager spheres depends on x = delta / delta_y, nu, beta, m and E / sigma_c; the radius
scales out exactly (tests/test_fem_similarity.py). While the contact is small against the
sphere the problem is that of two half-spaces and E / sigma_c drops out: F / Fy, delta_res /
delta_max, Wp / Wt, n_u and n_r are functions of (x; nu, beta, m) alone. E / sigma_c enters only
through the finite size of the sphere: a / R = (a_y / R) f(x) with a_y / R ~ sigma_c / E.

This module holds the study that shows it (``study_jobs``: FE runs at several E / sigma_c and the
same peaks in F / Fy; ``measure``: the normalised numbers of one run) and the finite-size
correction fitted from its data (``fit_finite_size``, ``finite_size_factor``).

    factor = finite_size_factor(depth=100.0, approach_over_radius=0.01)   # F / F_half-space
"""

from __future__ import annotations

import csv
import json
import math
import tomllib
from dataclasses import dataclass, replace
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

from ..errors import InputError
from ..fem.campaign import FemJob
from ..fem.identity import run_key
from ..fem.result import FemResult
from ..grain.hertz import incipient_yield
from ..grain.material import Material, preset
from .campaign import extract_run
from .fit import _power_exponent

DATASET = "similarity-data.csv"  # the study's normalised numbers, one row per FE run
CURVES = "similarity-curves.csv"  # the virgin loading curves, normalised
PROVENANCE = "similarity-data.json"  # inputs, versions, costs and the fitted correction
# Contacts below this fraction of R are taken as the half-space limit (their scatter about each
# other is the FE's, docs/similarity.md); the finite-size deviation is fitted above it.
HALF_SPACE_BELOW = 0.02
# The loading curves are compared from this x on (below it the first one or two load steps,
# whose contact spans the fewest elements).
MIN_CURVE_DEPTH = 0.5
# The finite-size correction is fitted up to this delta / R (a ~ 0.15 R): past it the small-strain
# FE is no longer credible (strains and rotations of a few per cent, docs/similarity.md; finite
# strain is issue 15).
FIT_MAX_APPROACH = 0.03
# Quantities whose finite-size deviation is fitted, and how: "ratio" F / F_hs - 1, or "shift"
# q - q_hs (a ratio already between 0 and 1).
FITTED = {"force": "ratio", "residual_ratio": "shift", "plastic_work_ratio": "shift",
          "unloading_exponent": "shift", "reloading_exponent": "shift"}


def settings() -> dict[str, Any]:
    """data/similarity.toml."""
    text = (resources.files("geocontact") / "data" / "similarity.toml").read_text()
    return tomllib.loads(text)


def study_material(base: Material, modulus_ratio: float) -> Material:
    """``base`` with sigma_c = E / ``modulus_ratio`` (E, nu, beta, m and R kept)."""
    if not (math.isfinite(modulus_ratio) and modulus_ratio > 1.0):
        raise InputError(f"modulus_ratio: E / sigma_c must be a number above 1, got "
                         f"{modulus_ratio!r}")
    return replace(base, compressive_yield_stress=base.youngs_modulus / modulus_ratio)


def limit_force_scale(material: Material) -> float:
    """sigma_c pi R^2: the scale of the load at which a perfectly plastic sphere yields through
    its whole cross-section (no equilibrium beyond it for m = 0)."""
    return material.compressive_yield_stress * math.pi * material.radius ** 2


@dataclass(frozen=True)
class StudyRun:
    """One run of the study: the grain (by its E / sigma_c), the peak in F / Fy, the FE job."""

    modulus_ratio_exponent: float
    peak_over_yield: float
    design_depth: float | None
    job: FemJob

    @property
    def modulus_ratio(self) -> float:
        return 10.0 ** self.modulus_ratio_exponent


def study_job(material: Material, peak_over_yield: float, mesh: str, history,
              steps_per_segment: int | None = None) -> FemJob:
    """The FE job of one study point: the history (waypoints in units of the peak) to
    ``peak_over_yield`` x the analytic Fy, its mesh sized for its own contact radii."""
    peak = peak_over_yield * incipient_yield(material).force
    ratio = material.youngs_modulus / material.compressive_yield_stress
    return FemJob(material, tuple(float(s) * peak for s in history), mesh=mesh,
                  steps_per_segment=steps_per_segment,
                  label=f"similarity E/sc=10^{math.log10(ratio):.2f} F/Fy={peak_over_yield:g} "
                        f"nu={material.poissons_ratio:g} beta={material.friction_angle_deg:g}")


def study_jobs(config: dict[str, Any] | None = None) -> list[StudyRun]:
    """Every run of the study (data/similarity.toml), the mesh checks last. A point whose
    design approach exceeds ``max_approach_over_radius`` x R, or whose peak exceeds
    ``max_force_over_limit`` x ``limit_force_scale``, is left out."""
    config = settings() if config is None else config
    study = config["study"]
    base = preset(study["material"])
    runs = []
    for exponent in study["modulus_ratio_exponents"]:
        material = study_material(base, 10.0 ** exponent)
        approach_y = incipient_yield(material).approach
        for peak, depth in zip(study["peaks_over_yield"], study["design_depths"], strict=True):
            if (depth * approach_y > study["max_approach_over_radius"] * material.radius
                    or peak * incipient_yield(material).force
                    > study["max_force_over_limit"] * limit_force_scale(material)):
                continue
            runs.append(StudyRun(exponent, peak, depth,
                                 study_job(material, peak, study["mesh"], study["history"])))
    axes = config.get("axes")
    if axes:
        material = study_material(base, 10.0 ** axes["modulus_ratio_exponent"])
        variants = [replace(material, friction_angle_deg=float(b))
                    for b in axes["friction_angle_deg"]]
        variants += [replace(material, poissons_ratio=float(n)) for n in axes["poissons_ratio"]]
        for variant in variants:
            for peak in axes["peaks_over_yield"]:
                runs.append(StudyRun(axes["modulus_ratio_exponent"], peak, None,
                                     study_job(variant, peak, study["mesh"], study["history"])))
    for check in config.get("mesh_check", []):
        material = study_material(base, 10.0 ** check["modulus_ratio_exponent"])
        runs.append(StudyRun(check["modulus_ratio_exponent"], check["peak_over_yield"], None,
                             study_job(material, check["peak_over_yield"], check["mesh"],
                                       study["history"])))
    return runs


def on_ratio_axis(row: dict[str, Any]) -> bool:
    """A row of the E / sigma_c axis: the study's mesh and the base grain's nu and beta."""
    study = settings()["study"]
    base = preset(study["material"])
    return (row["mesh"] == study["mesh"]
            and math.isclose(row["poissons_ratio"], base.poissons_ratio)
            and math.isclose(row["friction_angle_deg"], base.friction_angle_deg))


def measure(job: FemJob, result: FemResult) -> dict[str, Any]:
    """The normalised numbers of one load-unload-reload run: x = delta_max / delta_y,
    F / Fy, delta_res / delta_max, Wp / Wt (loop work over the work of loading), n_u and n_r
    (calibrate.fit's exponents), the FE first yield in units of the analytic one, the size of
    the contact against the sphere and the mesh's resolution of it, the cost.

    Fy and delta_y are the analytic first yield (geocontact.grain.hertz): exact functions of the
    inputs, so the normalisation adds no noise of its own; the FE's first yield is reported
    beside them."""
    material = job.material
    run = extract_run(job, result)
    level = run.level
    analytic = incipient_yield(material)
    n_u, err_u = _power_exponent(level.unloading_approach, level.unloading_force,
                                 level.residual_approach, level.max_approach, level.max_force)
    n_r, err_r = _power_exponent(level.reloading_approach, level.reloading_force,
                                 level.residual_approach, level.max_approach, level.max_force)
    summary = result.summary
    curve = result.curve
    peak = int(np.argmax(curve["force_N"]))
    resolution = summary["contact_resolution"]["elements_across_contact_radius"]
    radius = material.radius
    return {
        "modulus_ratio": material.youngs_modulus / material.compressive_yield_stress,
        "poissons_ratio": material.poissons_ratio,
        "friction_angle_deg": material.friction_angle_deg,
        "mesh": job.mesh,
        "peak_over_yield": level.max_force / analytic.force,
        "depth": level.max_approach / analytic.approach,
        "approach_over_radius": level.max_approach / radius,
        "contact_radius_over_radius": float(curve["contact_radius_m"][peak]) / radius,
        "yield_contact_radius_over_radius": analytic.contact_radius / radius,
        "force_over_limit": level.max_force / limit_force_scale(material),
        "residual_ratio": level.residual_approach / level.max_approach,
        "plastic_work_ratio": level.plastic_work / level.total_work,
        "dissipation_ratio": run.plastic_dissipation / level.total_work,
        "unloading_exponent": n_u,
        "reloading_exponent": n_r,
        "unloading_fit_rms": err_u,
        "reloading_fit_rms": err_r,
        "fe_yield_over_analytic": (summary["first_yield_force_N"] / analytic.force
                                   if summary.get("first_yield_force_N") else math.nan),
        "elements_across_contact_at_peak": resolution["peak"]["elements"],
        "elements_across_contact_at_yield": (resolution["first_yield"]["elements"]
                                             if resolution["first_yield"] else math.nan),
        "mesh_elements": summary["mesh"]["elements"],
        "steps": summary["steps"],
        "newton_iterations": summary["newton_iterations"],
        "wall_time_s": summary["wall_time_s"],
        "cache_key": run_key(result, job.identity()),
    }


def loading_curve(job: FemJob, result: FemResult) -> dict[str, np.ndarray]:
    """The virgin loading segment of a run in units of the analytic first yield: x, F / Fy,
    and a / R (the FE contact radius over the sphere radius)."""
    run = extract_run(job, result)
    analytic = incipient_yield(job.material)
    curve = result.curve
    steps = len(run.loading_force)
    first = int(result.summary["cycles"][0]["steps"][0])
    rows = {int(s): i for i, s in enumerate(curve["step"])}[first]
    contact = curve["contact_radius_m"][rows:rows + steps]
    return {"depth": run.loading_approach / analytic.approach,
            "force_over_yield": run.loading_force / analytic.force,
            "contact_radius_over_radius": contact / job.material.radius}


# --- the finite-size correction ----------------------------------------------------------------
# The deviation from the half-space curve at the same x, as a function of s = delta / R (known
# before any FE run: delta_y / R ~ (sigma_c / E)^2) and of x (docs/similarity.md), for every
# quantity (F / F_hs - 1 for the force, q - q_hs for the others):
#   e sqrt(s) + p s^k x^q
# e sqrt(s): the elastic term, first order in a / R ~ sqrt(s) (for the force: the approach is
# taken at the sphere's equator, not at infinity); p s^k x^q: the plastic zone reaching a fair
# part of R (the force falls, the residual approach and the dissipation grow).
PARAMETERS = ("elastic", "plastic", "size_power", "depth_power")


def finite_size_model(theta, approach_over_radius, depth) -> np.ndarray:
    """The fitted form of the deviation at (delta / R, x); ``theta`` in PARAMETERS' order."""
    elastic, plastic, k, q = theta
    s = np.asarray(approach_over_radius, dtype=float)
    x = np.asarray(depth, dtype=float)
    return elastic * np.sqrt(s) + plastic * s ** k * x ** q


@dataclass(frozen=True)
class FiniteSizeFit:
    """The least-squares fit of ``finite_size_model`` to a quantity's deviations over the points
    with delta / R <= ``max_approach_over_radius``: the parameters with their 1-sigma errors
    (from the fit's covariance), the RMS and largest residual, the ranges of s and x."""

    quantity: str
    kind: str
    parameters: dict[str, float]
    errors: dict[str, float]
    rms: float
    max_residual: float
    points: int
    approach_range: tuple[float, float]
    depth_range: tuple[float, float]
    yield_approach_max: float  # the largest delta_y / R among the fitted points (s / x)

    def deviation(self, approach_over_radius, depth) -> np.ndarray:
        theta = [self.parameters[name] for name in PARAMETERS]
        return finite_size_model(theta, approach_over_radius, depth)

    def to_dict(self) -> dict[str, Any]:
        form = ("F/F_hs - 1" if self.kind == "ratio" else "q - q_hs") \
            + " = elastic sqrt(s) + plastic s^size_power x^depth_power"
        return {"quantity": self.quantity, "kind": self.kind, "form": form + ", s = delta/R",
                "parameters": self.parameters, "errors": self.errors, "rms": self.rms,
                "max_residual": self.max_residual, "points": self.points,
                "approach_over_radius_range": list(self.approach_range),
                "depth_range": list(self.depth_range),
                "yield_approach_over_radius_max": self.yield_approach_max}


def half_space_interpolant(depth, values):
    """q_hs(x): monotone cubic interpolation in log x of the half-space reference points."""
    from scipy.interpolate import PchipInterpolator

    order = np.argsort(depth)
    x, q = np.log(np.asarray(depth)[order]), np.asarray(values)[order]
    keep = np.concatenate([[True], np.diff(x) > 1e-12])
    interpolant = PchipInterpolator(x[keep], q[keep], extrapolate=False)
    return lambda depth: interpolant(np.log(np.asarray(depth, dtype=float)))


def half_space_points(rows: list[dict[str, Any]], quantity: str,
                      below: float) -> dict[str, np.ndarray]:
    """The half-space curve of a peak quantity: per peak (in F / Fy), the mean x and the mean
    value over the E / sigma_c-axis runs whose contact stays below ``below`` x R, with their
    spread (standard deviation, the FE's own scatter between meshes of the same dimensionless
    size) and count."""
    small = [r for r in rows if on_ratio_axis(r) and r["contact_radius_over_radius"] < below]
    peaks = sorted({float(f"{r['peak_over_yield']:.4g}") for r in small})
    depth, value, spread, count = [], [], [], []
    for peak in peaks:
        mine = [r for r in small if math.isclose(r["peak_over_yield"], peak, rel_tol=1e-3)]
        depth.append(np.mean([r["depth"] for r in mine]))
        value.append(np.mean([r[quantity] for r in mine]))
        spread.append(np.std([r[quantity] for r in mine]))
        count.append(len(mine))
    return {"depth": np.array(depth), "value": np.array(value), "spread": np.array(spread),
            "count": np.array(count)}


def deviations(rows: list[dict[str, Any]], quantity: str, below: float,
               curves: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """The deviation from the half-space curve of every E / sigma_c-axis point (the reference's
    own left out), and the FE's scatter about that curve of the points whose contact stays
    below ``below`` x R (``floor``, RMS: what no finite-size effect can be told from).

    ``quantity`` "force": F / F_hs - 1 along the virgin loading curves (``curves``: rows of the
    curves file) at the same x, the half-space curve being that of the largest E / sigma_c
    (whose contact stays below ``below`` x R); other quantities: q - q_hs at each run's peak,
    the half-space curve through the means of the small-contact runs at each peak
    (``half_space_points``), interpolated in log x."""
    kind = FITTED.get(quantity, "shift")
    if quantity == "force":
        if curves is None:
            raise InputError("deviations: the force needs the loading curves")
        reference = max(c["modulus_ratio"] for c in curves)
        ref = [c for c in curves if math.isclose(c["modulus_ratio"], reference)]
        if max(c["contact_radius_over_radius"] for c in ref) >= below:
            raise InputError(f"deviations: the half-space reference (E/sigma_c = "
                             f"{reference:g}) reaches a >= {below:g} R")
        hs = half_space_interpolant([c["depth"] for c in ref],
                                    [c["force_over_yield"] for c in ref])
        points = [c for c in curves if not math.isclose(c["modulus_ratio"], reference)
                  and c["depth"] >= MIN_CURVE_DEPTH]
        q = np.array([c["force_over_yield"] for c in points])
    else:
        half = half_space_points(rows, quantity, below)
        hs = half_space_interpolant(half["depth"], half["value"])
        points = [r for r in rows if on_ratio_axis(r)]
        q = np.array([r[quantity] for r in points])
    x = np.array([p["depth"] for p in points])
    size_a = np.array([p["contact_radius_over_radius"] for p in points])
    ratio = np.array([p["modulus_ratio"] for p in points])
    expected = hs(x)
    deviation = q / expected - 1.0 if kind == "ratio" else q - expected
    known = np.isfinite(expected) & (size_a > 0)
    large = known & (size_a >= below)
    floor_points = known & (size_a < below)
    floor = float(np.sqrt(np.mean(deviation[floor_points] ** 2))) if floor_points.any() \
        else math.nan
    # delta / R from x and the grain's analytic delta_y / R (delta_y ~ (sigma_c / E)^2 R)
    approach = x * np.array([_yield_approach_over_radius(r) for r in ratio])
    return {"depth": x[known], "deviation": deviation[known],
            "contact_radius_over_radius": size_a[known],
            "approach_over_radius": approach[known], "modulus_ratio": ratio[known],
            "floor": floor, "floor_points": int(floor_points.sum()),
            "large_points": int(large.sum())}


def _yield_approach_over_radius(modulus_ratio: float) -> float:
    base = preset(settings()["study"]["material"])
    material = study_material(base, modulus_ratio)
    return incipient_yield(material).approach / material.radius


def fit_finite_size(data: dict[str, Any], quantity: str,
                    max_approach_over_radius: float) -> FiniteSizeFit:
    """Least-squares fit of ``finite_size_model`` (scipy curve_fit) to the deviations of
    ``deviations`` with delta / R <= ``max_approach_over_radius``; the errors are the square
    roots of the covariance's diagonal."""
    from scipy.optimize import curve_fit

    s = np.asarray(data["approach_over_radius"], dtype=float)
    x = np.asarray(data["depth"], dtype=float)
    d = np.asarray(data["deviation"], dtype=float)
    use = s <= max_approach_over_radius
    names = PARAMETERS
    if use.sum() <= len(names):
        raise InputError(f"finite-size fit of {quantity}: needs > {len(names)} points, got "
                         f"{use.sum()}")
    s, x, d = s[use], x[use], d[use]
    start = {"elastic": 0.1, "plastic": -0.1 if quantity == "force" else 0.1,
             "size_power": 1.0, "depth_power": 0.5}

    def model(points, *theta):
        return finite_size_model(theta, points[0], points[1])

    theta, cov = curve_fit(model, np.vstack([s, x]), d, p0=[start[n] for n in names],
                           maxfev=50000)
    residual = model(np.vstack([s, x]), *theta) - d
    return FiniteSizeFit(
        quantity, FITTED[quantity], dict(zip(names, map(float, theta), strict=True)),
        dict(zip(names, map(float, np.sqrt(np.diag(cov))), strict=True)),
        float(np.sqrt(np.mean(residual ** 2))), float(np.max(np.abs(residual))),
        int(use.sum()), (float(s.min()), float(s.max())), (float(x.min()), float(x.max())),
        float(np.max(s / x)))


# --- the committed dataset ---------------------------------------------------------------------
TEXT_COLUMNS = ("mesh", "cache_key")  # the dataset's columns that are not numbers


def read_rows(path) -> list[dict[str, Any]]:
    """Rows of a CSV written by the study: the TEXT_COLUMNS as text, the rest as floats."""
    with open(path, newline="") as handle:
        return [{key: value if key in TEXT_COLUMNS else float(value)
                 for key, value in row.items()} for row in csv.DictReader(handle)]


def _data_file(name: str):
    return resources.files("geocontact") / "data" / name


@cache
def shipped_fit() -> dict[str, Any]:
    """The finite-size fits recorded with the committed dataset (data/similarity-data.json)."""
    return json.loads(_data_file(PROVENANCE).read_text())["finite_size"]


def finite_size_factor(depth, approach_over_radius, *, quantity: str = "force",
                       fits: dict[str, Any] | None = None):
    """The finite-size correction of the study, fitted to the committed FE dataset
    (docs/similarity.md) for the reference (nu, beta, m) = (0.25, 30 deg, 0): at depth
    x = delta / delta_y and s = delta / R, the force's F / F_half-space (a factor near 1), or for
    the other quantities (``residual_ratio``, ``plastic_work_ratio``, ``unloading_exponent``,
    ``reloading_exponent``) the shift q - q_half-space.

    Outside the study's range of s and x (``shipped_fit()["fits"][quantity]``), or at a
    delta_y / R = s / x beyond its grains' (E / sigma_c < 10^2), it is refused. ``fits``: the
    "finite_size" record of another fit of the study (default: the shipped one)."""
    fits = shipped_fit() if fits is None else fits
    if quantity not in fits.get("fits", {}):
        raise InputError(f"quantity: {quantity!r} has no fitted finite-size correction "
                         f"(allowed: {', '.join(sorted(fits.get('fits', {})))})")
    fit = fits["fits"][quantity]
    s = np.asarray(approach_over_radius, dtype=float)
    x = np.asarray(depth, dtype=float)
    high = fit["approach_over_radius_range"][1]
    if np.any(~np.isfinite(s)) or np.any(s < 0) or np.any(s > high):
        raise InputError(f"approach_over_radius: must be in [0, {high:.3g}] (the study's "
                         f"range, docs/similarity.md), got {approach_over_radius!r}")
    low_x, high_x = fit["depth_range"]
    if np.any(~np.isfinite(x)) or np.any(x <= 0) or np.any(x > high_x):
        raise InputError(f"depth: x = delta/delta_y must be in (0, {high_x:.4g}] (the study's "
                         f"range), got {depth!r}")
    if np.any(s > x * fit["yield_approach_over_radius_max"] * (1.0 + 1e-9)):
        raise InputError(f"approach_over_radius: delta / R / x = delta_y / R must be at most "
                         f"{fit['yield_approach_over_radius_max']:.3g} (the study's grains, "
                         f"E / sigma_c >= 10^2), got {approach_over_radius!r} at x = {depth!r}")
    theta = [fit["parameters"][name] for name in PARAMETERS]
    deviation = finite_size_model(theta, s, x)
    out = 1.0 + deviation if fit["kind"] == "ratio" else deviation
    return float(out) if np.ndim(out) == 0 else out
