"""The universal law on the dataset of record (``record_dataset``): interpolation over the box of
record, the rebuild with levels by contact size, the fit, the cyclic extension and the calibrated
range from the interpolated top level.

    params = record_params(material, "datasets/universal/record")   # LawParams
    geocontact params --design record --dataset DIR --material M.toml --out P.json

As today's (``interpolate``): every law column is interpolated by scipy's RBFInterpolator on the
unit box, the kernel per column by leave-one-out (LOO); a dataset of fewer than
``interpolate.MIN_POINTS`` points (a pilot) takes the linear kernel with a constant polynomial,
which a degree-1 polynomial in 4 coordinates cannot do with so few nodes. The approach columns
need no baseline here: a level's position u = L/6 between the lowest peak and the top a/R is the
same at every point, so logx_L varies smoothly over the box (today's baseline took out the
drift of levels fixed in F/Fy; whether one helps here is for the LOO of the 64 points to say).

Then the law is rebuilt and fitted as today's (``interpolate.rebuild_from``, ``fit_law``), the
levels at their interpolated forces ``logf_L``; the cyclic extension is fitted by
``calibrate.campaign.fit_cyclic_analysis`` (as ``geocontact calibrate`` fits it) to the cycles
rebuilt from the interpolated repeated history (``record_dataset.rebuild_cycles``); and the
file's ``calibrated_range`` ends at the interpolated top level (its depth, force and a/R).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..grain.material import Material
from . import record
from .interpolate import KERNELS, MIN_POINTS, _fit_within_energy, _loo, _rbf, rebuild_from
from .record_dataset import (
    LEVEL_FIELDS,
    VIRGIN_SAMPLES,
    law_columns,
    parse_points_text,
    rebuild_cycles,
    virgin_force_grid,
)

GROUPS = {
    "fe_yield_ratio": ("fe_yield_ratio",),
    "top_log10_force": ("top_logf",),
    "virgin_log10_approach": ("virgin_logx_",),
    "level_log10_force": ("logf_",),
    "level_log10_contact_radius": ("contact_",),
    "level_log10_approach": ("logx_",),
    "residual_ratio": ("residual_",),
    "plastic_work_ratio": ("work_",),
    "unloading_exponent": ("unloading_exponent_",),
    "reloading_exponent": ("reloading_exponent_",),
    "cyclic_first_cycle": ("cyclic_logf", "cyclic_logx", "cyclic_residual", "cyclic_work"),
    "cyclic_log10_residual_increment_ratio": ("cyclic_residual_",),
    "cyclic_log10_dissipation_ratio": ("cyclic_dissipation_",),
}


def _in_group(column: str, prefixes) -> bool:
    return any(column == p or (p.endswith("_") and column.startswith(p)
                               and column[len(p):].isdigit()) for p in prefixes)


@dataclass
class RecordSurfaces:
    """The surfaces of one dataset of record and their LOO errors."""

    columns: list[str]
    nodes: np.ndarray
    values: np.ndarray
    kernels: list[str]
    degree: int
    loo_error: np.ndarray
    interpolators: dict[str, Any]
    dataset_sha256: str

    def __call__(self, coordinates) -> dict[str, float]:
        u = np.atleast_2d(record.unit(coordinates))
        out = np.empty(len(self.columns))
        for rbf, index in self.interpolators.values():
            out[index] = rbf(u)[0]
        return dict(zip(self.columns, out, strict=True))

    def expected_error(self, coordinates) -> dict[str, float]:
        """Per group: the largest over its columns of the inverse-square-distance mean of the
        nodes' LOO errors (as today's ``Surfaces.expected_error``)."""
        d2 = np.sum((self.nodes - record.unit(coordinates)) ** 2, axis=1)
        w = (d2 < 1e-24).astype(float) if np.any(d2 < 1e-24) else 1.0 / d2
        per_column = (w / w.sum()) @ self.loo_error
        return {group: float(np.max(per_column[[i for i, c in enumerate(self.columns)
                                                 if _in_group(c, prefixes)]]))
                for group, prefixes in GROUPS.items()}


def build_surfaces(data: dict[str, np.ndarray], sha256: str = "",
                   stored: dict[str, Any] | None = None) -> RecordSurfaces:
    """The surfaces of a dataset of record (``record_dataset.read_points``); ``stored``: the
    kernels and LOO errors ``prepare`` wrote to fits.json, used when they are of this dataset
    (its SHA-256) instead of recomputing the leave-one-out selection."""
    n = data["index"].size
    if n < 2:
        raise InputError(f"universal law (record): the dataset has {n} points; at least 2 "
                         "are needed (python -m geocontact.universal.campaign --design record)")
    columns = law_columns()
    nodes = record.unit(np.column_stack([data[name] for name in record.AXIS_NAMES]))
    values = np.column_stack([data[c] for c in columns])
    bad = [c for c in columns if not np.all(np.isfinite(data[c]))]
    if bad:
        raise InputError(f"universal law (record): the dataset has empty values in "
                         f"{', '.join(bad[:3])}")
    degree, kernels_tried = (1, KERNELS) if n >= MIN_POINTS else (0, ("linear",))
    if stored and sha256 and stored.get("dataset_sha256") == sha256 \
            and stored.get("columns") == columns:
        kernels = list(stored["kernels"])
        error = np.array(stored["loo_error"], dtype=float)
    else:
        errors = {k: _loo(nodes, values, k, degree) for k in kernels_tried}
        rms = np.array([np.sqrt(np.mean(errors[k] ** 2, axis=0)) for k in kernels_tried])
        rms[~np.all(np.isfinite(rms), axis=1)] = np.inf
        best = np.argmin(rms, axis=0)
        kernels = [kernels_tried[b] for b in best]
        error = np.column_stack([errors[kernels[j]][:, j] for j in range(len(columns))])
    interpolators = {}
    for kernel in kernels_tried:
        index = np.array([j for j, k in enumerate(kernels) if k == kernel], dtype=int)
        if index.size:
            interpolators[kernel] = (_rbf(nodes, values[:, index], kernel, degree), index)
    return RecordSurfaces(columns, nodes, values, kernels, degree, error, interpolators,
                          sha256)


def read_surfaces(directory: str | Path) -> tuple[RecordSurfaces, dict[str, np.ndarray]]:
    path = Path(directory) / "points.csv"
    if not path.is_file():
        raise InputError(f"dataset: no points.csv in {directory} (run python -m "
                         "geocontact.universal.campaign --design record)")
    text = path.read_bytes()
    data = parse_points_text(text.decode(), str(path))
    return build_surfaces(data, hashlib.sha256(text).hexdigest(), _stored(directory)), data


def _stored(directory: str | Path) -> dict[str, Any] | None:
    import json

    path = Path(directory) / FITS_FILE
    return json.loads(path.read_text()).get("surfaces") if path.is_file() else None


def normalised_data(values: dict[str, float]) -> dict[str, Any]:
    """The interpolated columns as ``interpolate.rebuild_from`` takes them: the virgin curve on
    the grid of the interpolated top force, the levels at their interpolated forces."""
    force = virgin_force_grid(values["top_logf"])
    logx = np.array([values[f"virgin_logx_{k:02d}"] for k in range(VIRGIN_SAMPLES)])
    levels = [{"force": float(10.0 ** values[f"logf_{level}"]),
               **{name: float(values[f"{name}_{level}"]) for name in LEVEL_FIELDS
                  if name not in ("logf", "contact", "second_increment")}}
              for level in range(record.LEVELS)]
    return {"virgin_force": force, "virgin_approach": 10.0 ** np.maximum.accumulate(logx),
            "levels": levels, "fe_yield_ratio": float(values["fe_yield_ratio"])}


FITS_FILE = "fits.json"
WARM_STARTS = 2


def row_key(data: dict[str, np.ndarray], i: int) -> str:
    """Hash of row i's coordinates and law columns (a node's entry holds while they do)."""
    cells = [f"{data[c][i]:.10g}" for c in (*record.AXIS_NAMES, *law_columns())]
    return hashlib.sha256(",".join(cells).encode()).hexdigest()[:16]


def prepare(directory: str | Path) -> int:
    """Write fits.json: per point, the law of record at the point itself (the interpolation is
    exact there): its saturating fits (the warm starts of ``record_params`` near it) and its
    cyclic extension's parameters and state. Returns the number of points fitted."""
    from dataclasses import asdict

    from ..files import write_json_atomic
    from .design import material_at

    surfaces, data = read_surfaces(directory)
    nodes = {}
    for i in range(data["index"].size):
        material = material_at([float(data[n][i]) for n in record.AXIS_NAMES])
        entry: dict[str, Any] = {"row": row_key(data, i)}
        try:
            p = record_params(material, directory, surfaces=surfaces, starts=None)
        except InputError as exc:  # recorded; such a node gives no warm start
            entry["error"] = str(exc)
        else:
            entry["residual"] = list(p.residual_closed_form("the law of record's warm starts"))
            entry["plastic_work"] = [p.plastic_work_limit, p.plastic_work_power,
                                     p.plastic_work_transition, p.plastic_work_log_power]
            entry["cyclic"] = {**asdict(p.cyclic), "status": p.provenance["cyclic"]["status"],
                               "state": p.provenance["cyclic"]["state"]}
        nodes[str(int(data["index"][i]))] = entry
    write_json_atomic(Path(directory) / FITS_FILE, {
        "format": "geocontact.universal-record-fits/1",
        "what": "per point of the campaign of record, the law of record at the point itself: "
                "its saturating fits (calibrate.fit.fit_law, 30-start grid), the warm starts of "
                "the law at a material near it, and its cyclic extension (calibrate's fit of "
                "the point's repeated history)",
        "command": "python -m geocontact.universal.campaign --design record (after each point)",
        "dataset_sha256": surfaces.dataset_sha256, "nodes": nodes,
        "surfaces": {"dataset_sha256": surfaces.dataset_sha256, "columns": surfaces.columns,
                     "kernels": surfaces.kernels, "loo_error": surfaces.loo_error}})
    return len(nodes)


def warm_starts(directory: str | Path, data: dict[str, np.ndarray], u: np.ndarray
                ) -> dict[str, list] | None:
    """The saturating fits of the ``WARM_STARTS`` points nearest to ``u`` (unit box) whose
    fits.json entry matches their row; None without any (then the fit's full grid)."""
    import json

    path = Path(directory) / FITS_FILE
    if not path.is_file():
        return None
    fits = json.loads(path.read_text()).get("nodes", {})
    nodes = record.unit(np.column_stack([data[n] for n in record.AXIS_NAMES]))
    chosen = []
    for i in np.argsort(np.sum((nodes - u) ** 2, axis=1)):
        entry = fits.get(str(int(data["index"][i])))
        if entry is not None and "residual" in entry and entry.get("row") == row_key(data, i):
            chosen.append(entry)
        if len(chosen) == WARM_STARTS:
            break
    return ({"residual": [e["residual"] for e in chosen],
             "plastic_work": [e["plastic_work"] for e in chosen]} if chosen else None)


def record_params(material: Material, directory: str | Path, *, extrapolate: bool = False,
                  surfaces: RecordSurfaces | None = None, starts: Any = "fits.json"):
    """The universal law of ``material`` from the dataset of record in ``directory``: its
    envelope, its cyclic extension and its calibrated range (module docstring)."""
    from ..calibrate.campaign import fit_cyclic_analysis
    from ..calibrate.cyclic_fit import analyse
    from .design import coordinates_of

    if not isinstance(material, Material):
        raise InputError(f"material: expected a geocontact.grain.material.Material, got "
                         f"{type(material).__name__}")
    problems = record.outside_range(material)
    if problems and not extrapolate:
        raise InputError(problems[0] + " (pass --extrapolate / extrapolate=True to accept "
                                       "it with a larger error)")
    table, nodes = (surfaces, None) if surfaces is not None else read_surfaces(directory)
    coords = coordinates_of(material)
    if starts == FITS_FILE:
        starts = None if nodes is None else warm_starts(directory, nodes, record.unit(coords))
    values = table(coords)
    data = normalised_data(values)
    yield_approach, d_virgin, f_virgin, levels, data, analytic = rebuild_from(material, data)
    provenance = {
        "source": "universal law of record (geocontact.universal.record_law): the campaign "
                  "of record's normalised data interpolated over material space, fitted by "
                  "calibrate.fit.fit_law",
        "universal": {
            "design": record.NAME,
            "dataset_sha256": table.dataset_sha256,
            "points": int(table.nodes.shape[0]),
            "coordinates": dict(zip(record.AXIS_NAMES, (float(c) for c in coords),
                                    strict=True)),
            "inside_range": not problems, "outside_range": problems,
            "expected_error_loo": table.expected_error(coords),
            "interpolation": {"polynomial_degree": table.degree,
                              "kernels": sorted(set(table.kernels))},
            "levels_force_over_yield": [lv["force"] for lv in data["levels_used"]],
            "levels_contact_over_radius": [float(10.0 ** values[f"contact_{k}"])
                                           for k in range(record.LEVELS)],
            "saturating_fit_start": ("the fits of the nearest campaign points (fits.json)"
                                     if starts else "the fit's full start grid"),
        },
    }
    params = _fit_within_energy(material, yield_approach, d_virgin, f_virgin, levels,
                                provenance, starts)
    params = with_record_range(params, values)
    analysis = analyse(rebuild_cycles(values, analytic.force, analytic.approach),
                       source="the universal law's interpolated repeated history")
    params = fit_cyclic_analysis(params, analysis, {
        "history": "the paper's repeated history at half the top level's force, its cycles "
                   "rebuilt from the interpolated columns (record_dataset.rebuild_cycles)"})
    return replace(params, label="universal (record)", yield_extra={
        "analytic_force_N": analytic.force, "analytic_approach_m": analytic.approach,
        "fe_over_analytic_force": data["fe_yield_ratio"],
        "source": "universal law: the FE first-yield force over the analytic one, "
                  "interpolated; approach = Hertz approach of that force"})


def with_record_range(params, values: dict[str, float]):
    """``calibrated_range`` of a law of record: ``fit_law``'s (the deepest level kept) with the
    contact radius over R the campaign reached there (interpolated ``contact_L``), and where it
    comes from."""
    u = params.provenance["universal"]
    used = len(u["levels_force_over_yield"])  # the top levels of the point (rebuild_from)
    kept = used - len(u.get("levels_left_out", []))
    top = record.LEVELS - used + kept - 1
    ratio = float(10.0 ** values[f"contact_{top}"])
    extra = {**params.calibrated_range_extra, "contact_radius_ratio": ratio,
             "source": f"the campaign of record's top level at this material: "
                       f"{u['levels_force_over_yield'][kept - 1]:.4g} Fy, a/R = {ratio:.3g} "
                       "(interpolated)"}
    return replace(params, calibrated_range_extra=extra)
