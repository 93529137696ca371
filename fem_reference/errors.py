"""Errors of the finite-element reference."""

from scenes.errors import DemesError


class FEMError(DemesError):
    """A scene the FEM reference cannot mesh or model: the message says why and what to change."""
