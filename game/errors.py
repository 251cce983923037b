"""The one exception type a user sees: a one-line message, never a traceback."""


class GameError(Exception):
    """A problem with the user's input or machine, reported as one line and a non-zero exit."""


class SceneError(GameError):
    """A scene file that does not follow the format (docs/reference.md, section 1)."""
