"""The core's integer ``info`` codes (core/sk_errors.f90, core/sk_cholmod.c)
mapped to exceptions.

Every wrapper in this package calls :func:`check` with the routine's name
and, optionally, routine-specific explanations, so that the message says
which routine failed and what was wrong with its input. The table below is
checked against the Fortran and C definitions by tests/test_architecture.py.
"""

from __future__ import annotations

from ..errors import ConvergenceError, DegenerateError, InputError, SingularError, StiffkitError

#: code -> (exception class, generic explanation)
INFO: dict[int, tuple[type[StiffkitError], str]] = {
    1: (InputError, "array sizes are too small or inconsistent"),
    2: (InputError, "the input contains NaN or Inf"),
    3: (
        DegenerateError,
        "the geometry does not determine the answer (nodes collinear or coincident: rotation unobservable)",
    ),
    4: (StiffkitError, "LAPACK reported a failure"),
    5: (SingularError, "a matrix that must be inverted is singular"),
    6: (InputError, "an argument is out of its range"),
    7: (ConvergenceError, "the iteration did not converge"),
    8: (InputError, "too few data are left for the estimate"),
    31: (InputError, "a file is missing, unreadable or malformed"),
    32: (StiffkitError, "out of memory"),
}

#: the names of the codes in core/sk_errors.f90 (sk_err_<name>), for the table test
NAMES: dict[int, str] = {
    1: "size",
    2: "nonfinite",
    3: "degenerate",
    4: "lapack",
    5: "singular",
    6: "argument",
    7: "noconv",
    8: "too_few",
    31: "io",
    32: "nomem",
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
