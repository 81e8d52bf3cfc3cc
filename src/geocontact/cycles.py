"""Moved to ``geocontact.analyses.cycles``; this name keeps working for a while."""

from .analyses.cycles import *  # noqa: F401,F403
from .analyses.cycles import __all__  # noqa: F401
