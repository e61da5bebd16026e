"""The one error type of jaxnav: a problem a user can fix, told in one line.

Every command catches :class:`JaxnavError` in one place (:func:`jaxnav.core.cli.run`),
prints ``<command>: error: <message>`` and exits with status 2. The subclasses say
where the problem is; none adds behaviour.
"""

from __future__ import annotations


class JaxnavError(Exception):
    """A user-fixable problem; the message is one line and names what is wrong."""


class ConfigError(JaxnavError, ValueError):
    """A config file, key or value; the message names the field."""


class MazeError(JaxnavError, ValueError):
    """A maze name or maze file."""


class RunError(JaxnavError):
    """A run directory or a file in it (missing, damaged, in use, from another config)."""


class PolicyError(JaxnavError, ValueError):
    """An exported policy file, or a scan or pose it cannot use."""
