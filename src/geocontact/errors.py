"""Typed errors. Every message is one line naming the field and the allowed range."""


class GeocontactError(Exception):
    """Base class of every error geocontact raises on purpose."""


class InputError(GeocontactError, ValueError):
    """Bad user input: a value out of range, an unknown key, a malformed file.

    The CLI prints ``error: <message>`` and exits with code 2.
    """


class ConvergenceError(GeocontactError, RuntimeError):
    """A solver did not converge; the message names the step and the load."""
