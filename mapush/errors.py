"""The one error type that the CLI turns into a single line and exit code 2."""


class BadInput(Exception):
    """A user-facing mistake: names the bad value and the valid choices. Never a traceback."""


def first_line(err: BaseException) -> str:
    """The first line of an error's message (or its type's name when it has none), for a one-line BadInput."""
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__
