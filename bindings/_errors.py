"""Map the core's integer ``info`` codes (core/sk_errors.f90) to exceptions.

Every wrapper calls :func:`check` with the routine's name and, optionally, a
dictionary of routine-specific explanations, so the message says which
routine failed and what was wrong with the input.
"""
from __future__ import annotations


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


# code -> (exception class, generic explanation); keep in step with sk_errors.f90
INFO = {
    1: (InputError, "array sizes are too small or inconsistent"),
    2: (InputError, "the input contains NaN or Inf"),
    3: (DegenerateError, "the geometry does not determine the answer "
                         "(nodes collinear or coincident: rotation unobservable)"),
    4: (StiffkitError, "LAPACK reported a failure"),
    5: (SingularError, "a matrix that must be inverted is singular"),
    6: (InputError, "an argument is out of its range"),
    7: (ConvergenceError, "the iteration did not converge"),
    8: (InputError, "too few data are left for the estimate"),
    31: (InputError, "a file is missing, unreadable or malformed"),
    32: (StiffkitError, "out of memory"),
}


def check(info: int, routine: str, details: dict[int, str] | None = None) -> None:
    """Raise the exception that ``info`` stands for, naming ``routine``."""
    info = int(info)
    if info == 0:
        return
    cls, text = INFO.get(info, (StiffkitError, f"unknown status {info}"))
    if details and info in details:
        text = details[info]
    raise cls(f"{routine}: {text} (info={info})")
