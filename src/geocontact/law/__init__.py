"""The hysteretic normal contact law (docs/model.md §6): parameters, the scalar reference path
and the vectorised many-contact kernel."""

from .calibrated_range import BeyondCalibratedRangeError, BeyondCalibratedRangeWarning
from .kernel import ContactArrays
from .params import SCHEMA, SHAKEDOWN, TRUNCATED, CyclicLaw, LawParams, load_params
from .reference import BRANCH_NAMES, Contact, ContactState, force_history

__all__ = [
    "BRANCH_NAMES",
    "BeyondCalibratedRangeError",
    "BeyondCalibratedRangeWarning",
    "SCHEMA",
    "SHAKEDOWN",
    "TRUNCATED",
    "Contact",
    "ContactArrays",
    "ContactState",
    "CyclicLaw",
    "LawParams",
    "force_history",
    "load_params",
]
