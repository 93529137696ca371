"""The error a bad scene raises: it names the field and says how to fix it."""


class SceneError(ValueError):
    """A scene field is missing, of the wrong type, or out of range."""
