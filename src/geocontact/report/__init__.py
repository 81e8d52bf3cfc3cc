"""Self-contained HTML reports of run directories (``geocontact report DIR``): ``html`` (the page,
its figures embedded, each figure's data as CSV beside it), one module per section (``fe``,
``law``, ``sweeps``, ``seismic``, ``cycles``, ``paper_histories``) and ``build`` (which section
each result gets)."""

from ..figures import Figure, save_figure
from .html import GENERATOR, Report, is_our_report, render_html, table

__all__ = ["GENERATOR", "Figure", "Report", "build_report", "is_our_report", "render_html",
           "save_figure", "table"]


def build_report(*args, **kwargs):
    """``report.build.build_report`` (imported on use: the sections need the analyses)."""
    from .build import build_report as build

    return build(*args, **kwargs)
