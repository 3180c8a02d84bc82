"""The two kinds of failure the command line tells apart.

`UsageError` is bad input (a value the user can fix): the CLI prints one line
and exits 2.  `RenderFailure` is something that went wrong at run time
(a kernel build failed, the device ran out of memory): exit 1.
"""


class UsageError(ValueError):
    """Bad input: the message names the value and what is allowed."""


class RenderFailure(RuntimeError):
    """A failure at run time that is not the user's input."""


def require(condition: bool, message: str) -> None:
    """Raise UsageError(message) unless condition holds."""
    if not condition:
        raise UsageError(message)
