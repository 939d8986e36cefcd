"""The exceptions stiffkit raises on purpose.

Every check of user input raises :class:`InputError` (or a subclass) with a
message naming the file, row or key and the value; the command line turns
any :class:`StiffkitError` into one line and exit status 2. The core's
integer ``info`` codes map onto these classes in ``stiffkit._core.errors``.
"""

from __future__ import annotations

__all__ = [
    "StiffkitError",
    "InputError",
    "DegenerateError",
    "SingularError",
    "ConvergenceError",
    "StiffkitWarning",
    "PlausibilityWarning",
]


class StiffkitError(Exception):
    """Base class of every error stiffkit raises on purpose."""


class InputError(StiffkitError, ValueError):
    """The input is malformed: wrong shapes, NaN/Inf, out-of-range values."""


class DegenerateError(InputError):
    """The input does not determine the answer (e.g. collinear nodes)."""


class SingularError(StiffkitError, ArithmeticError):
    """A matrix that must be inverted is singular."""


class ConvergenceError(StiffkitError, RuntimeError):
    """An iteration of the core did not converge."""


class StiffkitWarning(UserWarning):
    """Base class of the warnings stiffkit emits on purpose (the command line
    prints each as one line ``stiffkit COMMAND: warning: ...``)."""


class PlausibilityWarning(StiffkitWarning):
    """A value is valid but implausible for its unit (e.g. a length of
    1000 m, a joint angle of 90 rad): most likely a unit slip. The message
    names the value, the likely unit and the fix."""
