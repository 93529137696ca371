"""Errors of the DR solver."""

from scenes.errors import DemesError


class DRError(DemesError):
    """Bad model input: the message names the argument and says how to fix it."""
