"""The calibrated range of an FE calibration written before files carried it, from the file's
own record: no FE run, no refit, every other number unchanged.

``geocontact calibrate`` writes ``calibrated_range`` from its FE levels (``fit_law``: the
deepest level's delta_max/delta_y, approach and force; ``campaign.fe_calibrated_range``: its
contact radius over R when the FE summary records it). A calibration made before holds the
same numbers already: the levels' depths in ``fit_errors.per_level`` (``depth`` =
delta_max/delta_y of each level, computed with the file's delta_y) and their peaks in
``provenance.fe.peak_forces_N``, in the same order as the FE runs' ``cache_keys``. This writes
the block from them, as a rerun of ``calibrate`` would (``scripts/check_calibrations.py``
compares the two), and keeps the file and its acceptance table naming each other by hash::

    python scripts/add_calibrated_range.py examples/params-reference-weak.json

``--cache DIR``: the FE cache holding the runs (default: the one the file records,
``provenance.inputs.cache``); when the deepest run's ``summary.json`` is there, its contact
radius at the peak gives ``contact_radius_ratio``; else the ratio is left out (not known).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from geocontact.calibrate.campaign import fe_calibrated_range
from geocontact.calibrate.workflow import check_acceptance
from geocontact.errors import ArgumentParser, InputError, run_reporting_errors
from geocontact.files import write_json_atomic, write_text_atomic
from geocontact.law.params import LawParams, load_params


def from_record(params: LawParams, cache: str | Path | None = None) -> LawParams:
    """``params`` with its calibrated range from its own record (module docstring)."""
    fe = params.provenance.get("fe", {})
    per_level = params.fit_errors.get("per_level")
    peaks, keys = fe.get("peak_forces_N"), fe.get("cache_keys")
    if not per_level or not peaks or len(peaks) != len(per_level):
        raise InputError("params: not an FE calibration with its levels recorded "
                         "(fit_errors.per_level and provenance.fe.peak_forces_N)")
    depth = np.array([level["depth"] for level in per_level], dtype=float)
    deepest = int(np.argmax(depth))
    summary = None
    cache = cache if cache is not None else params.provenance.get("inputs", {}).get("cache")
    if cache is not None and keys and len(keys) == len(peaks):
        path = Path(cache) / keys[deepest] / "summary.json"
        summary = json.loads(path.read_text()) if path.is_file() else None
    extra = fe_calibrated_range(float(depth[deepest]) * params.yield_approach,
                                float(peaks[deepest]), len(per_level), summary,
                                params.material.radius)
    return replace(params, calibrated_depth=float(depth[deepest]),
                   calibrated_range_extra=extra)


def rewrite(path: str | Path, cache: str | Path | None = None) -> LawParams:
    """Add the calibrated range to the file at ``path`` (and relink its acceptance table)."""
    return rewrite_linked(path, lambda params: from_record(params, cache))


def rewrite_linked(path: str | Path, change) -> LawParams:
    """Rewrite the law file at ``path`` as ``change(params)`` and relink its acceptance table,
    if the two were written together (the table's ``params_sha256`` is the new file's)."""
    path = Path(path)
    table_path = path.with_suffix(".acceptance.json")
    linked = table_path.is_file() and not check_acceptance(path)
    params = change(load_params(path))
    text = params.to_json()
    if linked:
        table = json.loads(table_path.read_text())
        table["params_sha256"] = hashlib.sha256(text.encode()).hexdigest()
        write_json_atomic(table_path, table)
    write_text_atomic(path, text)
    return params


def rewrite_main(prog: str, doc: str, change, describe, argv: list[str] | None = None) -> int:
    """The command line of a script that rewrites FE calibration files in place:
    ``prog P.json [P.json ...] [--cache DIR]``; each file becomes ``change(params, cache)``
    (its acceptance table relinked, ``rewrite_linked``) and ``describe(params)`` is printed
    after its name. Errors are one line (``run_reporting_errors``)."""
    parser = ArgumentParser(prog=f"python scripts/{prog}", description=doc.split("\n\n")[0])
    parser.add_argument("params", nargs="+", help="FE calibration files (P.json), rewritten")
    parser.add_argument("--cache", default=None, help="FE cache of the runs (default: the "
                                                      "file's provenance.inputs.cache)")

    def run() -> int:
        args = parser.parse_args(argv)
        for name in args.params:
            params = rewrite_linked(name, lambda p: change(p, args.cache))
            print(f"{name}: {describe(params)}")
        return 0

    return run_reporting_errors(run)


def main(argv: list[str] | None = None) -> int:
    return rewrite_main("add_calibrated_range.py", __doc__, from_record,
                        lambda p: f"calibrated_range {json.dumps(p.calibrated_range)}", argv)


if __name__ == "__main__":
    raise SystemExit(main())
