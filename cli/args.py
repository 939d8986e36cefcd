"""Option types of the command line: every number an option takes is parsed
and checked (finite, in range, plausible for its unit) by the validation
layer (stiffkit.io.validate) while the arguments are parsed, so a bad value
stops the command before any work with one line naming the option."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Collection

import numpy as np

from ..errors import InputError
from ..io import validate as V

__all__ = ["number", "count", "vector", "numbers_list", "choice_list"]


def _float(text: str, option: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{option} {text!r} is not a number") from None


def number(option: str, q: str | None = None, **limits: object) -> Callable[[str], float]:
    """A float option checked as ``validate.number(value, option, q, **limits)``."""

    def parse(text: str) -> float:
        try:
            return V.number(_float(text, option), option, q, **limits)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    parse.__name__ = "number"
    return parse


def count(option: str, lo: int = 1, hi: int | None = None) -> Callable[[str], int]:
    """An integer option in [lo, hi]."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} {text!r} is not an integer") from None
        try:
            return V.count(v, option, lo, hi)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    parse.__name__ = "count"
    return parse


def vector(text: str, n: int, option: str, q: str | None = None) -> np.ndarray:
    """'1,2,3' -> n checked floats (InputError naming the option)."""
    parts = [x.strip() for x in str(text).split(",")]
    try:
        vals = [float(x) for x in parts]
    except ValueError:
        raise InputError(f"{option} {text!r}: expected {n} comma-separated numbers") from None
    if len(vals) != n:
        raise InputError(f"{option} {text!r}: expected {n} comma-separated numbers, got {len(vals)}")
    return V.array(vals, option, (n,), q)


def numbers_list(
    text: str, option: str, kind: type[int] | type[float] = float, q: str | None = None, **limits: object
) -> list:
    """'5,3,2' -> a non-empty list of checked numbers (ints with kind=int)."""
    parts = [x.strip() for x in str(text).split(",") if x.strip()]
    if not parts:
        raise InputError(f"{option} {text!r}: an empty list")
    out = []
    for x in parts:
        try:
            v = kind(x)
        except ValueError:
            what = "an integer" if kind is int else "a number"
            raise InputError(f"{option} {text!r}: {x!r} is not {what}") from None
        out.append(V.number(v, option, q, integer=kind is int, **limits))
    return out


def choice_list(text: str, option: str, choices: Collection[str]) -> list[str]:
    """'a,b' -> names, each one of ``choices``."""
    items = [x.strip() for x in str(text).split(",") if x.strip()]
    if not items:
        raise InputError(f"{option} {text!r}: an empty list")
    bad = [x for x in items if x not in choices]
    if bad:
        raise InputError(f"{option}: unknown {', '.join(bad)}; choose from {', '.join(choices)}")
    return items
