"""Errors of the DR solver."""


class DRError(ValueError):
    """Bad model input: the message names the argument and says how to fix it."""
