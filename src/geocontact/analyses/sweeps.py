"""Material influence (the paper's "Influence of material properties"): FE sweeps of E, beta,
sigma_c and m at a fixed peak force, with the paper's statements checked by numbers.

The sweeps and the paper's statements live in ``data/sweeps.toml``. Every sweep point is one FE
run 0 -> Fmax -> 0 (run as a Dask campaign with a cache, ``geocontact.fem.campaign``); from it:

* ``secant_stiffness`` Fmax / delta_max (the paper's "nonlinear spring stiffness"),
* ``normalised_stiffness`` (Fmax/Fy) / (delta_max/delta_y), the slope of the paper's F/Fy
  against delta/delta_y plot (the paper does not say which of the two it calls stiffness),
* ``peak_over_yield`` Fmax / Fy with the analytic incipient-yield force,
* ``residual_ratio`` delta_res / delta_max and ``plastic_work_ratio`` Wp / Wtotal,
* the normalised curves F/Fmax against delta/delta_max and F/Fy against delta/delta_y.

A statement's trend is ``increasing`` / ``decreasing`` (every step of the sweep moves that way),
``constant`` (max/min - 1 within the file's ``constant_tolerance``) or ``varies`` (not constant).
"""

from __future__ import annotations

import sys
import tomllib
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..fem.campaign import DEFAULT_CACHE, FemJob, run_campaign
from ..fem.result import FemResult
from ..files import atomic_directory, check_replaceable, provenance, write_csv, write_json_atomic
from ..grain.hertz import incipient_yield
from ..grain.material import Material, preset

SCHEMA = "geocontact.sweeps/1"
QUANTITIES = ("secant_stiffness", "normalised_stiffness", "peak_over_yield", "residual_ratio",
              "plastic_work_ratio")
TRENDS = ("increasing", "decreasing", "constant", "varies")


def load_sweeps(text: str | None = None) -> dict[str, Any]:
    """The shipped sweep definitions (``data/sweeps.toml``, or that file's ``text``), checked."""
    if text is None:
        text = (resources.files("geocontact") / "data" / "sweeps.toml").read_text()
    data = tomllib.loads(text)
    for name, sweep in data["sweep"].items():
        values = [float(v) for v in sweep["values"]]
        # a trend is read step by step along the sweep: a repeated point would read as a
        # non-monotone trend (a false disagreement with the paper), an unsorted one as reversed
        if len(values) < 2 or np.any(np.diff(values) <= 0):
            raise InputError(f"sweeps.toml: sweep {name}: values must be >= 2 strictly "
                             f"increasing numbers (no repeated point), got {sweep['values']}")
        for statement in sweep.get("statements", []):
            if statement["quantity"] not in QUANTITIES or statement["trend"] not in TRENDS:
                raise InputError(f"sweeps.toml: sweep {name}: bad statement {statement}")
    return data


def sweep_materials(definition: dict, names: list[str]) -> list[tuple[str, float, Material]]:
    base = preset(definition["base"])
    points = []
    for name in names:
        sweep = definition["sweep"].get(name)
        if sweep is None:
            raise InputError(f"sweeps: unknown sweep {name!r} "
                             f"(allowed: {', '.join(definition['sweep'])})")
        for value in sweep["values"]:
            points.append((name, float(value),
                           replace(base, **{sweep["parameter"]: float(value)})))
    return points


def point_metrics(material: Material, result: FemResult) -> dict[str, float]:
    """The scalar outcomes of one sweep point (single cycle to the peak and back)."""
    y = incipient_yield(material)
    cycle = result.summary["cycles"][0]
    curve = result.curve
    peak = int(np.argmax(curve["force_N"]))
    total_work = float(curve["work_J"][peak])
    return {
        "yield_force_N": y.force,
        "yield_approach_m": y.approach,
        "fe_first_yield_force_N": result.summary.get("first_yield_force_N"),
        "fully_plastic_force_N": result.summary.get("fully_plastic_force_N"),
        "max_force_N": cycle["max_force_N"],
        "max_approach_m": cycle["max_approach_m"],
        "residual_approach_m": cycle["residual_approach_m"],
        "plastic_work_J": cycle["plastic_work_J"],
        "total_work_J": total_work,
        "secant_stiffness": cycle["max_force_N"] / cycle["max_approach_m"],
        "normalised_stiffness": (cycle["max_force_N"] / y.force)
        / (cycle["max_approach_m"] / y.approach),
        "peak_over_yield": cycle["max_force_N"] / y.force,
        "depth": cycle["max_approach_m"] / y.approach,
        "residual_ratio": cycle["residual_approach_m"] / cycle["max_approach_m"],
        "plastic_work_ratio": cycle["plastic_work_J"] / total_work,
    }


def trend(values, tolerance: float) -> str:
    """increasing / decreasing (strictly, step by step), constant (spread within tolerance),
    else non-monotone."""
    v = np.asarray(values, dtype=float)
    if v.max() <= (1.0 + tolerance) * v.min():
        return "constant"
    d = np.diff(v)
    if np.all(d > 0):
        return "increasing"
    if np.all(d < 0):
        return "decreasing"
    return "non-monotone"


def check_statement(statement: dict, values, tolerance: float) -> dict[str, Any]:
    found = trend(values, tolerance)
    expected = statement["trend"]
    agrees = found != "constant" if expected == "varies" else found == expected
    v = np.asarray(values, dtype=float)
    return {"statement": statement["text"], "quantity": statement["quantity"],
            "expected": expected, "found": found, "agrees": bool(agrees),
            "values": [float(x) for x in v], "spread": float(v.max() / v.min() - 1.0)}


def _curves(material: Material, result: FemResult) -> dict[str, np.ndarray]:
    """Loading and unloading of the first cycle, normalised both ways."""
    y = incipient_yield(material)
    f, d = result.curve["force_N"], result.curve["approach_m"]
    peak = int(np.argmax(f))
    return {"approach_over_max": d / d[peak], "force_over_max": f / f[peak],
            "approach_over_yield": d / y.approach, "force_over_yield": f / y.force,
            "unloading": (np.arange(len(f)) > peak).astype(int)}


def run_sweeps(out: str | Path, names: list[str] | None = None, *, mesh: str = "default",
               peak_force: float | None = None, steps_per_segment: int | None = None,
               cache_dir: str | Path = DEFAULT_CACHE,
               scheduler: str | None = None, workers: int | None = None,
               progress: bool = True, overwrite: bool = False) -> dict[str, Any]:
    """Run the sweeps (all by default) and write ``out``: summary.json (every point's numbers
    and every statement's verdict), points.csv and curves_<sweep>.csv. Returns the summary.
    ``out`` is replaced only if it is a sweep result of ours (``io.check_replaceable``, checked
    before the FE campaign; ``overwrite`` lifts it)."""
    check_replaceable(out, "sweep", overwrite=overwrite)
    definition = load_sweeps()
    # a sweep named twice (--sweeps E,E) is that sweep once: run twice, its points would be
    # listed twice and its trend read as non-monotone, a false disagreement with the paper
    names = list(dict.fromkeys(names or definition["sweep"]))
    fmax = float(peak_force if peak_force is not None else definition["peak_force"])
    if not np.isfinite(fmax) or fmax <= 0:
        raise InputError(f"peak_force: must be a positive number of newtons, got {fmax}")
    points = sweep_materials(definition, names)
    jobs = [FemJob(m, (0.0, fmax, 0.0), mesh=mesh, steps_per_segment=steps_per_segment,
                   label=f"{s}={v:g}") for s, v, m in points]
    results = run_campaign(jobs, cache_dir, scheduler=scheduler, workers=workers,
                           progress=progress)
    tolerance = float(definition["constant_tolerance"])
    summary: dict[str, Any] = {
        "schema": SCHEMA, "peak_force_N": fmax, "mesh": mesh, "base": definition["base"],
        "constant_tolerance": tolerance, "sweeps": {},
        "provenance": provenance("sweep", {"sweeps": names, "peak_force_N": fmax,
                                           "mesh": mesh, "steps_per_segment": steps_per_segment,
                                           "definitions": definition["sweep"]}),
    }
    table: dict[str, list] = {"sweep": [], "value": []}
    curves: dict[str, dict[str, np.ndarray]] = {name: {} for name in names}
    for (name, value, material), job, result in zip(points, jobs, results, strict=True):
        metrics = point_metrics(material, result)
        entry = summary["sweeps"].setdefault(name, {
            "parameter": definition["sweep"][name]["parameter"],
            "label": definition["sweep"][name]["label"],
            "scale": definition["sweep"][name]["scale"], "points": []})
        entry["points"].append({"value": value, "fe_cache_key": job.key(),
                                "fe_wall_time_s": result.summary["wall_time_s"], **metrics})
        table["sweep"].append(name)
        table["value"].append(value)
        for key in QUANTITIES + ("max_approach_m", "residual_approach_m", "plastic_work_J",
                                 "yield_force_N", "depth"):
            table.setdefault(key, []).append(metrics[key])
        for col, arr in _curves(material, result).items():
            curves[name][f"{col}@{value:g}"] = arr
    for name in names:
        entry = summary["sweeps"][name]
        entry["statements"] = [
            check_statement(st, [p[st["quantity"]] for p in entry["points"]], tolerance)
            for st in definition["sweep"][name].get("statements", [])]
    with atomic_directory(out, "sweep", overwrite=overwrite) as tmp:
        write_csv(tmp / "points.csv", {k: np.asarray(v) for k, v in table.items()})
        for name in names:
            write_csv(tmp / f"curves_{name}.csv", curves[name])
        write_json_atomic(tmp / "summary.json", summary)
    if progress:
        agree = sum(s["agrees"] for e in summary["sweeps"].values() for s in e["statements"])
        total = sum(len(e["statements"]) for e in summary["sweeps"].values())
        print(f"sweeps: {len(points)} FE runs, {agree}/{total} of the paper's statements "
              f"agree -> {out}", file=sys.stderr)
    return summary
