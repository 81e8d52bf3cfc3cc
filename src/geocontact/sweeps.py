"""Moved to ``geocontact.analyses.sweeps``; this name keeps working for a while."""

from .analyses.sweeps import *  # noqa: F401,F403
