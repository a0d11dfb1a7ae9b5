"""The one error type that the CLI turns into a single line and exit code 2."""


class BadInput(Exception):
    """A user-facing mistake: names the bad value and the valid choices. Never a traceback."""
