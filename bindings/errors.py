"""The core's integer ``info`` codes (core/sk_errors.f90, core/sk_status.h)
mapped to exceptions.

Every wrapper in this package calls :func:`check` with the routine's name
and, optionally, routine-specific explanations, so that the message says
which routine failed and what was wrong with its input. The table below is
checked against the Fortran and C definitions by tests/test_architecture.py.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from ..errors import ConvergenceError, DegenerateError, InputError, SingularError, StiffkitError

_T = TypeVar("_T")

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
    9: (
        InputError,
        "a compliance or stiffness has a negative eigenvalue (or a joint a negative compliance): not a physical spring",
    ),
    10: (
        InputError,
        "the result is not finite: the input magnitudes are beyond double precision (check their units)",
    ),
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
    9: "indefinite",
    10: "overflow",
    31: "io",
    32: "nomem",
}


#: argument codes of the kinematic-tree core's errloc[0] (core/sk_tree_check.f90,
#: arg_<name>): code -> (argument, what errloc[1] counts, 1-based); checked
#: against the Fortran table by tests/test_tree_errors.py
TREE_ARGUMENTS: dict[int, tuple[str, str]] = {
    1: ("vparent", "virtual joint"),
    2: ("vtype", "virtual joint"),
    3: ("vaxis", "virtual joint"),
    4: ("vrot", "virtual joint"),
    5: ("vpos", "virtual joint"),
    6: ("qcol", "virtual joint"),
    7: ("qcoef", "virtual joint"),
    8: ("qconst", "virtual joint"),
    9: ("gvj", "geometric entry"),
    10: ("gpar", "geometric entry"),
    11: ("gcoef", "geometric entry"),
    12: ("ktype", "elastic block"),
    13: ("kvj", "elastic block"),
    14: ("kpar", "elastic block"),
    15: ("kw0", "elastic block"),
    16: ("bvj", "body"),
    17: ("bmass", "body"),
    18: ("bcom", "body"),
    19: ("grav", ""),
    20: ("tpar", "tracker parameter"),
    21: ("rref", ""),
    22: ("mvj", "marker"),
    23: ("mpar", "marker"),
    24: ("ne", ""),
    25: ("theta", "parameter"),
    26: ("q", "posture"),
    27: ("lpost", "payload"),
    28: ("lvj", "payload"),
    29: ("lw", "payload"),
    30: ("opost", "observation"),
    31: ("omark", "observation"),
    32: ("oxyz", "observation"),
    33: ("owt", "observation"),
    34: ("free", "free parameter"),
    35: ("frame", "row"),
    36: ("rtarget", "row"),
    37: ("ptarget", "row"),
    38: ("prow", "per-row parameter"),
    39: ("trow", "row"),
    40: ("etol", ""),
}


def located(routine: str, info: int, where: str, problem: str) -> StiffkitError:
    """The exception of ``info`` with a message naming the argument and the
    index (``where``) and what is wrong (``problem``)."""
    cls = INFO.get(int(info), (StiffkitError, ""))[0]
    exc = cls(f"{routine}: {where}: {problem}")
    exc.info = int(info)
    return exc


def check(info: int, routine: str, details: dict[int, str] | None = None) -> None:
    """Raise the exception that ``info`` stands for, naming ``routine`` and
    saying what was wrong (the code itself is the exception's ``info``
    attribute, not part of the message: it means nothing to a user)."""
    info = int(info)
    if info == 0:
        return
    cls, text = INFO.get(info, (StiffkitError, f"unknown status {info}"))
    if details and info in details:
        text = details[info]
    exc = cls(f"{routine}: {text}")
    exc.info = info
    raise exc


def call(fn: Callable[..., _T], routine: str, *args: object, **kwargs: object) -> _T:
    """``fn(*args, **kwargs)`` of an f2py extension, with the extension's
    own argument errors (ValueError, TypeError: an array that does not
    convert, a wrong size) raised as InputError naming ``routine``."""
    try:
        return fn(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        text = " ".join(str(exc).split())
        raise InputError(f"{routine}: the arguments do not fit the core's signature ({text})") from None
