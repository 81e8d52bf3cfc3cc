"""Moved to ``geocontact.analyses.paper_histories``; this name keeps working for a while."""

from .analyses.paper_histories import *  # noqa: F401,F403
from .analyses.paper_histories import __all__  # noqa: F401
