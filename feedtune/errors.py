"""Exceptions that carry a one-line, user-facing message and an exit code.

The command line turns every :class:`FeedtuneError` into one line on stderr and the exit code it carries:
2 for usage errors (bad options, unknown commands), 1 for data errors (bad files, failed fits, unstable
designs). Library users catch them like ordinary exceptions.
"""

from __future__ import annotations


class FeedtuneError(Exception):
    """Base class: a problem the user can act on, described in one line."""

    exit_code = 1


class DataError(FeedtuneError):
    """Input data are missing, malformed or unusable (exit code 1)."""

    exit_code = 1


class UsageError(FeedtuneError):
    """An option or parameter has an invalid value (exit code 2)."""

    exit_code = 2


class DesignError(FeedtuneError):
    """A design is unstable or violates the requested limits (exit code 1)."""

    exit_code = 1


class IllConditionedError(DataError):
    """A least-squares problem has no reliable solution (reason in the message)."""
