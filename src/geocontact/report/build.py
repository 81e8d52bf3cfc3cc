"""``geocontact report DIR``: recognise the results in a run directory and turn each into a
report section (figures from the results' own data, each figure's data as CSV beside it);
figures/ and report.html are written as results of ours.

Recognised, in DIR itself and in its immediate sub-directories:

* an FE run (``curve.csv`` + ``summary.json`` with ``cycles``): force-approach curve, energies;
* law parameters (``*.json`` with ``"schema": "geocontact.law/1"``): the law's curves, residual
  approach and plastic work against depth with the FE points it was fitted to;
* material sweeps (``summary.json`` with ``"schema": "geocontact.sweeps/1"``);
* a seismic run (``summary.json`` with ``events``; its own figures are embedded);
* a cyclic-history run (``geocontact cycles``: ``summary.json`` with ``analyses``): the ratios of
  cycle N to cycle 1 with their power laws, the shakedown states and critical cycles;
* the paper's loading-history study (``findings.json``);
* a DEM run (``geocontact dem``: ``summary.json`` with ``"schema": "geocontact.dem/1"``), and
  an oedometer on several samples (``--seeds``: ``"schema": "geocontact.dem-seeds/1"``);
* a laboratory-test fit (``geocontact fit``: ``fit.json`` with
  ``"schema": "geocontact.labfit/1"``).

Sections for other result kinds register themselves in ``SECTIONS`` (first match wins).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..errors import InputError
from ..files import (
    add_to_manifest,
    atomic_directory,
    provenance,
    write_text_atomic,
)
from .common import (
    FIGURES,
    REPORT_HTML,
)
from .cycles import cycles_section, is_cycles
from .dem import dem_section, is_dem
from .dem_cyclic import dem_cyclic_section, is_dem_cyclic
from .dem_seeds import dem_seeds_section, is_dem_seeds
from .fe import fe_section, is_fe_run
from .html import Report, is_our_report, render_html
from .labfit import is_labfit, labfit_section
from .law import law_files, law_section
from .paper_histories import is_paper_histories, paper_histories_section
from .seismic import is_seismic, seismic_section
from .sweeps import is_sweeps, sweeps_section

SECTIONS: list[tuple[Callable[[Path], bool], Callable]] = [
    (is_paper_histories, paper_histories_section),
    (is_sweeps, sweeps_section),
    (is_seismic, seismic_section),
    (is_cycles, cycles_section),
    (is_dem, dem_section),
    (is_dem_cyclic, dem_cyclic_section),
    (is_dem_seeds, dem_seeds_section),
    (is_labfit, labfit_section),
    (is_fe_run, fe_section),
]


def build_report(directory: str | Path, title: str | None = None, intro: str = "",
                 preface: list[tuple[str, list]] | None = None, *,
                 overwrite: bool = False) -> Path:
    """Write DIR/report.html (and DIR/figures/) from every result found in DIR; ``preface``:
    (heading, items) sections placed first (the demo's own tables and figures).

    ``figures/`` is written as one unit (no stale figure of an earlier report survives) and
    then ``report.html``; either is replaced only if an earlier report wrote it (unless
    ``overwrite``), and both join DIR's result manifest when DIR is a result of ours."""
    root = Path(directory)
    if not root.is_dir():
        raise InputError(f"report: not a directory: {directory}")
    html_path = root / REPORT_HTML
    if html_path.exists() and not overwrite and not is_our_report(html_path):
        raise InputError(f"report: {html_path} exists and was not written by geocontact; "
                         "refusing to replace it: move it or pass overwrite=True")
    report = Report(title=title or f"geocontact — {root.name}", intro=intro,
                    provenance=provenance("report", {"directory": str(root)}))
    for heading, items in preface or []:
        report.add(heading, *items)
    found = len(preface or [])
    with atomic_directory(root / FIGURES, "report", overwrite=overwrite) as figures:
        subs = sorted(p for p in root.iterdir()
                      if p.is_dir() and p.name != FIGURES and not p.name.startswith("."))
        for sub in [root] + subs:
            for path in law_files(sub):
                law_section(report, path, root, figures)
                found += 1
            for test, section in SECTIONS:
                if test(sub):
                    section(report, sub, root, figures)
                    found += 1
                    break
        if not found:
            raise InputError(f"report: no geocontact results found in {directory} (looked for "
                             "FE runs, law parameter files, sweeps, seismic runs, cyclic "
                             "histories, DEM runs)")
        text = render_html(report, root, figures)
    write_text_atomic(html_path, text)
    add_to_manifest(root, [REPORT_HTML])
    return html_path
