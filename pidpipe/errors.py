"""Errors that pidpipe reports to its users.

Every user-facing failure is a :class:`PidpipeError`; the CLI and the workflow scripts print
its message (no traceback) and exit non-zero. Programming errors stay ordinary exceptions.
"""


class PidpipeError(Exception):
    """Base class: a failure the user can act on, with a message that says how."""


class ConfigError(PidpipeError):
    """The configuration is invalid; the message names the key, the value and what is allowed."""


class PackingError(PidpipeError):
    """The spheres of a case cannot be placed (for example they do not fit below the lid)."""


class EngineError(PidpipeError):
    """LIGGGHTS is missing, failed, or produced output that cannot be trusted."""


class ParseError(PidpipeError):
    """Engine output is missing, truncated or malformed."""


class TableError(PidpipeError):
    """A C_eq table is missing columns or values, or has too few points to fit."""


class DomainError(PidpipeError):
    """A query lies outside the domain where a surrogate is valid."""
