"""The contact radius of an FE calibration written before files carried it, fitted to the same
FE runs the file was calibrated on: no FE run and no refit of the force law, every other number
unchanged (docs/law.md, "The contact radius").

``geocontact calibrate`` fits ``contact_radius`` from its FE levels (``calibrate.contact_radius``,
called by ``campaign.fit_runs``). A calibration made before names its runs in
``provenance.fe.cache_keys``; this loads them from the FE cache and writes the block and its
errors (``fit_errors.contact_radius``) as a rerun of ``calibrate`` would
(``scripts/check_calibrations.py`` compares the two), keeping the file and its acceptance table
naming each other by hash::

    python scripts/add_contact_radius.py examples/params-reference-weak.json

``--cache DIR``: the FE cache holding the runs (default: the file's ``provenance.inputs.cache``).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from add_calibrated_range import rewrite_main  # noqa: E402  (a sibling script)

from geocontact.calibrate.campaign import radius_level
from geocontact.calibrate.contact_radius import fit_contact_radius
from geocontact.errors import InputError
from geocontact.fem.identity import load_result
from geocontact.law.params import LawParams


def from_runs(params: LawParams, cache: str | Path | None = None) -> LawParams:
    """``params`` with its contact radius fitted to its own FE runs (module docstring)."""
    keys = params.provenance.get("fe", {}).get("cache_keys")
    cache = cache if cache is not None else params.provenance.get("inputs", {}).get("cache")
    if not keys or cache is None:
        raise InputError("params: not an FE calibration with its runs recorded "
                         "(provenance.fe.cache_keys and provenance.inputs.cache)")
    missing = [k for k in keys if not (Path(cache) / k / "summary.json").is_file()]
    if missing:
        raise InputError(f"--cache: {cache} lacks {len(missing)} of the file's {len(keys)} FE "
                         f"runs (first: {missing[0]}); give the cache that holds them")
    levels = [radius_level(load_result(Path(cache) / key)) for key in keys]
    table, errors = fit_contact_radius([lv for lv in levels if lv is not None],
                                       params.yield_approach, params.material.effective_radius)
    if not table:
        raise InputError("params: no FE level is plastic with branches to fit the radius to")
    return replace(params, radius_table=table,
                   fit_errors={**params.fit_errors, "contact_radius": errors})


def describe(params: LawParams) -> str:
    worst = max(e["rms"] for e in params.fit_errors["contact_radius"]["below_envelope"])
    return (f"contact_radius with {len(params.radius_table.depth)} knots; largest RMS below "
            f"the envelope {worst:.2%}")


def main(argv: list[str] | None = None) -> int:
    return rewrite_main("add_contact_radius.py", __doc__, from_runs, describe, argv)


if __name__ == "__main__":
    raise SystemExit(main())
