"""The project's errors: every one names what is wrong and how to fix it.

:class:`DemesError` is the base of the errors of every package (``SceneError`` here,
``dr.DRError``, ``fem_reference.FEMError``): the ``demes`` command catches it and prints its
one-line message; anything else reaching the user is a bug.
"""


class DemesError(ValueError):
    """Bad input to the project (a scene, a model, a setting, a path): the message says which
    and how to fix it."""


class SceneError(DemesError):
    """A scene field is missing, of the wrong type, or out of range."""
