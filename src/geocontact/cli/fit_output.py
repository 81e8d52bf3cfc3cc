"""What ``geocontact fit`` writes: the law file ``P.json`` (``geocontact.law/1``, validated by
the schema before it is written) and the result folder ``P.fit/`` beside it (``fit.json``, the
conditioned record with the law driven along it in ``curve.csv``, the figures), written
atomically with its manifest; ``geocontact report P.fit`` turns the folder into a report."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np
from scipy.signal import savgol_filter

from ..errors import InputError
from ..files import (
    atomic_directory,
    check_file_replaceable,
    check_replaceable,
    write_csv,
    write_json_atomic,
)
from ..labtest.curve import SMOOTH_WINDOW
from ..labtest.fit import LabFit
from ..law import Contact, LawParams

SCHEMA = "geocontact.labfit/1"
COMMAND = "fit"
# branch codes of curve.csv
BRANCHES = {0: "before contact", 1: "virgin loading", 2: "unloading", 3: "reloading",
            4: "lift-off (zero force)"}


def folder_of(out: str | Path) -> Path:
    """``P.fit`` beside ``P.json``."""
    out = Path(out)
    return out.with_name(out.stem + ".fit")


def check_outputs(out: str | Path, overwrite: bool = False) -> tuple[Path, Path]:
    """Fail at once (before any work) on an --out that cannot be written."""
    out = Path(out)
    if out.suffix != ".json":
        raise InputError(f"out: expected a .json file name, got {str(out)!r}")
    check_file_replaceable(out, overwrite=overwrite, field="out")
    folder = folder_of(out)
    check_replaceable(folder, COMMAND, overwrite=overwrite)
    return out, folder


def branches(result: LabFit) -> np.ndarray:
    """Branch code of every point (``BRANCHES``)."""
    t = result.test
    code = np.zeros(t.force.size, dtype=int)
    for c in t.cycles:
        s = c.loading()
        idx = np.arange(s.start, s.stop)
        code[idx] = np.where(t.approach[idx] > c.previous_max_approach, 1, 3)
        code[np.arange(c.peak + 1, c.end + 1)] = 2
    code[(code > 0) & (t.force < 3.0 * t.noise) & (code != 1)] = 4
    code[t.approach <= 0.0] = 0
    return code


def law_along(params: LawParams, approach) -> tuple[np.ndarray, np.ndarray]:
    """The law driven along the record's approach, smoothed (the transducer noise would be
    read as micro-reversals); returns the smoothed approach and the law's force."""
    d = np.asarray(approach, dtype=float)
    window = min(SMOOTH_WINDOW, d.size - (1 - d.size % 2))
    smooth = savgol_filter(d, window, 2)
    contact = Contact(params)
    force = np.array([contact.update(float(max(a, 0.0)))[0] for a in smooth])
    return smooth, force


def path_rms_percent(approach, error, peak: float) -> float:
    """RMS of ``error`` over the path length (|d approach| weights), % of ``peak``
    (``calibrate.acceptance``'s measure)."""
    step = np.abs(np.diff(approach))
    w = np.zeros_like(approach)
    w[:-1] += 0.5 * step
    w[1:] += 0.5 * step
    return float(100.0 * np.sqrt(np.sum(w * error**2) / np.sum(w)) / peak)


def summary(result: LabFit, params_path: Path, law_rms: float) -> dict[str, Any]:
    p = result.params
    m = p.material
    se = (result.bootstrap or {}).get("standard_errors", {})
    values = result.values()
    return {
        "schema": SCHEMA,
        "params_file": params_path.name,
        "test": result.test.inputs(),
        "material": {"values": m.to_dict(), "standard_errors": {
            "youngs_modulus": se.get("youngs_modulus_Pa"),
            "compressive_yield_stress": se.get("compressive_yield_stress_Pa")}},
        "fitted": {k: {"value": v, "standard_error": se.get(k)} for k, v in values.items()},
        "given": result.given,
        "assumed": result.assumed,
        "contact_point": result.contact,
        "yield": result.yield_info,
        "departure_from_hertz": result.departure,
        "identification": {k: v for k, v in result.identification.items()},
        "sigma_c_of_beta": result.sigma_c_of_beta,
        "cycles": result.levels,
        "fit_errors": {k: v for k, v in p.fit_errors.items() if k != "per_level"},
        "law_along_record": {"force_rms_percent_of_peak": law_rms,
                             "definition": "law driven along the smoothed measured approach; "
                                           "RMS over the path length, % of the peak force"},
        "bootstrap": {k: v for k, v in (result.bootstrap or {}).items()
                      if k not in ("standard_errors",)},
        "branches": BRANCHES,
    }


def write_fit(result: LabFit, out: str | Path, *, overwrite: bool = False,
              inputs: dict | None = None) -> dict[str, Any]:
    """Write ``P.json`` and ``P.fit/``; returns the folder's summary. The parameter file is
    validated by the schema (read back through ``LawParams.from_dict``) before anything is
    written."""
    from ..report.labfit import draw_fit_figures

    out, folder = check_outputs(out, overwrite)
    params = result.params
    LawParams.from_dict(params.to_dict())  # the schema and the rules between fields
    t = result.test
    smooth, law_force = law_along(params, t.approach)
    law_rms = path_rms_percent(smooth, law_force - t.force, t.peak_force)
    document = summary(result, out, law_rms)
    columns = {"approach_m": t.approach, "force_N": t.force, "law_approach_m": smooth,
               "law_force_N": law_force,
               "branch": branches(result), "displacement_m": t.record.displacement,
               "raw_force_N": t.record.force}
    if t.record.time is not None:
        columns = {"time_s": t.record.time, **columns}
    text = params.to_json()
    document["params_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    with atomic_directory(folder, COMMAND, overwrite=overwrite,
                          inputs=inputs or t.inputs()) as tmp:
        write_csv(tmp / "curve.csv", columns)
        write_json_atomic(tmp / "fit.json", document)
        draw_fit_figures(tmp, tmp)
        params.save(out)
    return document
