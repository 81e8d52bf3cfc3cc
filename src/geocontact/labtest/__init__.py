"""Laboratory tests: the law (and the material) fitted to a measured single-grain
force-displacement curve (``geocontact fit``, docs/fit.md)."""

from .curve import LabTest, Record, approach_of, condition, read_test
from .fit import LabFit, fit_test

__all__ = ["LabFit", "LabTest", "Record", "approach_of", "condition", "fit_test", "read_test"]
