"""Moved to ``geocontact.analyses.force_driven`` (the law under force control); this name keeps
working for a while."""

from .analyses.force_driven import LawRun, drive_by_force  # noqa: F401
from .force_history import PRESETS, load_history, preset_history  # noqa: F401
