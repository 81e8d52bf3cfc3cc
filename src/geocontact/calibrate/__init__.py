"""Calibration of the law from FE cycles (docs/model.md §7)."""

from .fit import LevelData, fit_law, fit_loading

__all__ = ["LevelData", "fit_law", "fit_loading"]
