"""Moved to ``geocontact.report`` (one module per section, ``report.build``); this name keeps
working for a while."""

from .report.build import SECTIONS, build_report  # noqa: F401
