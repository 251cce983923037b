"""The one exception type a user sees: a one-line message, never a traceback."""


class GameError(Exception):
    """A problem with the user's input or machine, reported as one line and a non-zero exit."""


class SceneError(GameError):
    """A scene file that does not follow the format (docs/reference.md, section 1)."""


def printable(text: str) -> str:
    """``text`` with every control character escaped (``\\n``, ``\\x1b``): a file name or a key
    from a user cannot break a message's one line, move the cursor or command the terminal."""
    return "".join(ch if ch.isprintable() or ch == " " else ch.encode("unicode_escape").decode()
                   for ch in text)
