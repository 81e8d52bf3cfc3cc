"""A whole calibration as one call: FE campaign, fit, P.json, and (optionally) the held-out
acceptance with its table, CSVs and figures. ``geocontact calibrate`` and the demo use it."""

from __future__ import annotations

import hashlib
import json
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..files import (
    atomic_directory,
    check_replaceable,
    json_safe,
    provenance,
    read_manifest,
    write_json_atomic,
    write_text_atomic,
)
from ..grain.material import Material
from ..law.params import LawParams
from .acceptance import (
    acceptance_table,
    compare,
    draw_comparison_figures,
    run_acceptance,
    write_comparison_data,
)
from .campaign import CalibrationRun, calibrate
from .fit import REGIMES, SATURATING


def calibrate_to_file(material: Material, out: str | Path, inputs: dict[str, Any], *,
                      peaks=None, levels: int | None = None, max_force: float | None = None,
                      acceptance: bool = False, overwrite: bool = False,
                      residual_form: str = SATURATING, loading_form: str = REGIMES,
                      **campaign) -> tuple[
                          LawParams, list[CalibrationRun], dict[str, Any] | None]:
    """Calibrate, write ``out`` (P.json) and, with ``acceptance``, ``out.acceptance.json`` and
    the folder ``out.acceptance/`` (one CSV + PNG per compared run). ``campaign``: mesh,
    steps_per_segment, cache_dir, scheduler, workers, progress, fe_model (see ``calibrate``;
    the held-out runs use the same FE model). ``residual_form``, ``loading_form``: of the
    fitted residual approach and virgin curve (``fit_law``).

    The three are one result: the figures folder lands first (whole, so no stale figure
    survives), then the table, then P.json; each names the other by hash (P.json's
    ``provenance.acceptance.sha256`` is the table's, the table's ``params_sha256`` is P.json's),
    so a pair left mismatched by an interrupt is seen as such (``check_acceptance``). Without
    ``acceptance``, an earlier acceptance of ours beside ``out`` is removed (it no longer
    describes the file)."""
    out = Path(out)
    folder = out.with_suffix(".acceptance")
    if acceptance:
        check_replaceable(folder, "calibrate", overwrite=overwrite)  # before the campaign
    params, runs = calibrate(material, peaks=peaks, levels=levels, max_force=max_force,
                             residual_form=residual_form, loading_form=loading_form,
                             **campaign)
    record = provenance("calibrate", inputs)
    record.pop("geocontact_version")  # LawParams.to_dict writes it first
    params = replace(params, provenance={**params.provenance, **record})
    if not acceptance:
        params.save(out)
        _remove_stale_acceptance(out)
        return params, runs, None
    fitted = [compare(params, r.job, r.result, name=f"fitted-{i}", kind="fitted",
                      description=f"calibration run, peak {r.level.max_force:.4g} N")
              for i, r in enumerate(runs, 1)]
    held = run_acceptance(params, material, max_force=max_force, **campaign)
    comparisons = fitted + held
    table = acceptance_table(comparisons)
    table["params"] = out.name
    table["figures"] = folder.name
    table["provenance"] = provenance("calibrate --acceptance", inputs)
    params = replace(params, provenance={**params.provenance, "acceptance": {
        "file": out.with_suffix(".acceptance.json").name, "figures": folder.name,
        "sha256": _document_hash(table)}})
    params_text = params.to_json()
    table["params_sha256"] = hashlib.sha256(params_text.encode()).hexdigest()
    with atomic_directory(folder, "calibrate", overwrite=overwrite,
                          inputs={"params": out.name}) as tmp:
        write_comparison_data(comparisons, tmp)
        draw_comparison_figures(comparisons, tmp)
    write_json_atomic(out.with_suffix(".acceptance.json"), table)
    write_text_atomic(out, params_text)
    return params, runs, table


def _document_hash(document: dict[str, Any]) -> str:
    text = json.dumps(json_safe(document), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def check_acceptance(params_path: str | Path) -> list[str]:
    """What breaks the link between P.json and its acceptance table (empty when they were
    written together and neither changed since): the table's record of P.json's hash, and
    P.json's record of the table's."""
    params_path = Path(params_path)
    table_path = params_path.with_suffix(".acceptance.json")
    try:
        params_text = params_path.read_text()
        link = json.loads(params_text).get("provenance", {}).get("acceptance")
        table = json.loads(table_path.read_text())
    except (OSError, ValueError) as exc:
        return [f"{params_path}: acceptance unreadable ({exc})"]
    problems = []
    if table.pop("params_sha256", None) != hashlib.sha256(params_text.encode()).hexdigest():
        problems.append(f"{table_path} was not written with this {params_path.name} (hash differs)")
    if not isinstance(link, dict) or link.get("sha256") != _document_hash(table):
        problems.append(f"{params_path.name} does not reference this {table_path.name}")
    return problems


def _remove_stale_acceptance(out: Path) -> None:
    """An acceptance of ours left beside ``out`` by an earlier calibration describes another
    P.json: remove it (only what carries our marks: the folder's manifest, the table's hash)."""
    folder = out.with_suffix(".acceptance")
    manifest = read_manifest(folder) if folder.is_dir() else None
    if manifest is not None and manifest.get("command") == "calibrate":
        shutil.rmtree(folder)
    table = out.with_suffix(".acceptance.json")
    try:
        ours = "params_sha256" in json.loads(table.read_text())
    except (OSError, ValueError, AttributeError):
        ours = False
    if ours:
        table.unlink()
