"""A whole calibration as one call: FE campaign, fit, P.json, and (optionally) the held-out
acceptance with its table, CSVs and figures. ``geocontact calibrate`` and the demo use it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from ..io import provenance, write_json_atomic
from ..law.params import LawParams
from ..material import Material
from .acceptance import (
    acceptance_table,
    compare,
    draw_comparison_figures,
    run_acceptance,
    write_comparison_data,
)
from .campaign import CalibrationRun, calibrate


def calibrate_to_file(material: Material, out: str | Path, inputs: dict[str, Any], *,
                      peaks=None, levels: int | None = None, max_force: float | None = None,
                      acceptance: bool = False, **campaign) -> tuple[
                          LawParams, list[CalibrationRun], dict[str, Any] | None]:
    """Calibrate, write ``out`` (P.json) and, with ``acceptance``, ``out.acceptance.json`` and
    the folder ``out.acceptance/`` (one CSV + PNG per compared run). ``campaign``: mesh,
    steps_per_segment, cache_dir, scheduler, workers, progress (see ``calibrate``)."""
    out = Path(out)
    params, runs = calibrate(material, peaks=peaks, levels=levels, max_force=max_force,
                             **campaign)
    record = provenance("calibrate", inputs)
    record.pop("geocontact_version")  # LawParams.to_dict writes it first
    params = replace(params, provenance={**params.provenance, **record})
    params.save(out)
    if not acceptance:
        return params, runs, None
    fitted = [compare(params, r.job, r.result, name=f"fitted-{i}", kind="fitted",
                      description=f"calibration run, peak {r.level.max_force:.4g} N")
              for i, r in enumerate(runs, 1)]
    held = run_acceptance(params, material, max_force=max_force, **campaign)
    comparisons = fitted + held
    folder = out.with_suffix(".acceptance")
    write_comparison_data(comparisons, folder)
    draw_comparison_figures(comparisons, folder)
    table = acceptance_table(comparisons)
    table["params"] = out.name
    table["figures"] = folder.name
    table["provenance"] = provenance("calibrate --acceptance", inputs)
    write_json_atomic(out.with_suffix(".acceptance.json"), table)
    return params, runs, table
