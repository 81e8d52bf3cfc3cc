"""Moved to ``geocontact.analyses.seismic``; this name (and its modules: ``records``,
``analysis``, ``column``, ``classify``, ``figures``) keeps working for a while."""

import sys

from ..analyses import seismic as _moved
from ..analyses.seismic import analysis, classify, column, figures, records  # noqa: F401

for _name in ("analysis", "classify", "column", "figures", "records"):
    sys.modules[f"{__name__}.{_name}"] = getattr(_moved, _name)
