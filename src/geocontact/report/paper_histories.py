"""Report section of the paper's loading-history study (``scripts/paper_histories.py``): its
findings table."""

from __future__ import annotations

import json
from html import escape as html_escape
from pathlib import Path

from ..errors import InputError
from .html import Report, table


def is_paper_histories(directory: Path) -> bool:
    return (directory / "findings.json").is_file()


def paper_histories_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    """The paper's loading-history findings (scripts/paper_histories.py) against our numbers."""
    from ..analyses.paper_histories import format_value as _compact

    try:
        findings = json.loads((directory / "findings.json").read_text())["findings"]
    except (json.JSONDecodeError, KeyError) as exc:
        raise InputError(f"{directory / 'findings.json'}: malformed ({exc})") from None
    evaluated = [f for f in findings if not f.get("missing_runs")
                 and not str(f["our_value"]).startswith("not available")]
    rows = [[f["statement"], f["quantity"], _compact(f["our_value"]),
             _compact(f.get("paper_value")),
             "undecided" if f["agrees"] is None else ("agrees" if f["agrees"] else "disagrees")]
            for f in evaluated]
    items = ["<p>From <code>scripts/paper_histories.py</code> (repeated, monotonically "
             "decreasing and increasing histories to 3000 N for σc = 10 and 1 MPa, and a von "
             "Mises grain); the rule behind each verdict is in <code>findings.json</code>.</p>",
             table(["paper's statement", "quantity", "ours", "paper", "verdict"], rows)]
    left_out = len(findings) - len(evaluated)
    if left_out:
        needed = sorted({run for f in findings if f not in evaluated
                         for run in f.get("missing_runs", f.get("runs", []))})
        items.append(f"<p>{left_out} more of the paper's statements need runs this directory "
                     f"does not hold ({html_escape(', '.join(needed))}): "
                     "<code>python scripts/paper_histories.py</code> runs the whole study.</p>")
    report.add("The paper's findings on loading histories", *items)
