"""Self-contained HTML reports: figures embedded (base64 PNG), each figure's data as CSV beside
it, every number traceable to the run that made it."""

from __future__ import annotations

import base64
import html
import json
from dataclasses import dataclass, field
from pathlib import Path

from .._version import __version__
from ..figures import Figure


@dataclass
class Report:
    title: str
    intro: str
    provenance: dict
    sections: list = field(default_factory=list)  # (heading, [Figure | str])

    def add(self, heading: str, *items) -> None:
        self.sections.append((heading, list(items)))


GENERATOR = "geocontact"  # the <meta name="generator"> of every report we write


def is_our_report(path: str | Path) -> bool:
    """Whether ``path`` is an HTML report geocontact wrote (its generator tag)."""
    try:
        head = Path(path).read_text(errors="replace")[:2000]
    except OSError:
        return False
    return f"<meta name='generator' content='{GENERATOR}" in head


def render_html(report: Report, directory: Path, figures: Path | None = None) -> str:
    """The report as one self-contained HTML page. Images are read from ``directory`` (paths
    relative to it); those under ``figures/`` from ``figures`` when given (the figures folder
    being written beside it)."""

    def image(rel: str) -> Path:
        head, _, rest = rel.partition("/")
        if figures is not None and head == "figures" and rest:
            return figures / rest
        return directory / rel

    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<meta name='generator' content='{GENERATOR} {__version__}'>",
        f"<title>{html.escape(report.title)}</title>",
        "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}"
        "img{max-width:100%}table{border-collapse:collapse}td,th{border:1px solid #bbb;"
        "padding:2px 6px}figcaption{color:#444}</style></head><body>",
        f"<h1>{html.escape(report.title)}</h1><p>{report.intro}</p>",
    ]
    for heading, items in report.sections:
        parts.append(f"<h2>{html.escape(heading)}</h2>")
        for item in items:
            if isinstance(item, Figure):
                png = image(item.image or f"{item.name}.png").read_bytes()
                data = base64.b64encode(png).decode()
                csv_name = item.data_file or (f"{item.name}.csv" if item.data else "")
                csv_note = f" Data: <code>{csv_name}</code>." if csv_name else ""
                parts.append(f"<figure><img alt='{html.escape(item.title)}' "
                             f"src='data:image/png;base64,{data}'><figcaption><b>"
                             f"{html.escape(item.title)}.</b> {item.caption}{csv_note}"
                             "</figcaption></figure>")
            else:
                parts.append(item)
    parts.append("<h2>Provenance</h2><pre>" + html.escape(json.dumps(report.provenance,
                                                                        indent=2)) + "</pre>")
    parts.append("</body></html>")
    return "\n".join(parts)


def table(headers: list[str], rows: list[list]) -> str:
    def cell(v):
        return f"{v:.4g}" if isinstance(v, float) else html.escape(str(v))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"
