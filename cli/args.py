"""Option types of the command line: every number an option takes is parsed
and checked (finite, in range, plausible for its unit) by the validation
layer (stiffkit.io.validate) while the arguments are parsed, so a bad value
stops the command before any work with one line naming the option."""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Callable, Collection

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..robot import catalogue

__all__ = ["number", "count", "vector", "numbers_list", "choice_list", "kinds_help"]


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


def kinds_help(data: str, indent: int = 2, width: int = 100) -> str:
    """The kinds of data kind ``data`` for a command's --help (``stiffkit fit
    --help``), one entry each, from the catalogue (robot/catalogue.py): its
    law, its target, its parameters as printed after ``<target>.`` with
    their units, what its other keys mean (``usage``, else their names) and
    whether it needs a ``joint`` effect on its joint."""
    nb = "\xa0"  # a unit or a parenthesis is not broken across lines

    def keep(text: str) -> str:
        out, depth = [], 0
        for ch in text.replace("`", ""):
            depth += (ch == "(") - (ch == ")")
            out.append(nb if ch == " " and depth > 0 else ch)
        return "".join(out)

    out = []
    for e in catalogue.ENTRIES:
        if data not in e.data:
            continue
        groups: list[tuple[list[str], str]] = []  # consecutive parameters of one unit
        for p in e.params:
            if groups and groups[-1][1] == p.unit:
                groups[-1][0].append(p.suffix)
            else:
                groups.append(([p.suffix], p.unit))
        params = e.params_text or ", ".join(f"{', '.join(names)} ({unit})" for names, unit in groups)
        parts = [e.formula]
        if e.target != "none":
            parts.append(f"target = {e.target}")
        parts.append(f"parameters {params}")
        if e.value_key != "value":
            parts.append(f"a known value as {e.value_key} = ...")
        extra = sorted(e.keys[data] - {"target", "value", e.value_key})
        if e.usage:
            parts.append(e.usage)
        elif extra:
            parts.append(f"keys {', '.join(extra)}")
        if data in e.needs_joint:
            parts.append("needs a joint effect on the same joint")
        lines = textwrap.wrap(
            keep("; ".join(parts)),
            width,
            initial_indent=f"{' ' * indent}{e.name:20s} ",
            subsequent_indent=" " * (indent + 21),
            break_on_hyphens=False,
        )
        out += [line.replace(nb, " ") for line in lines]
    return "\n".join(out)
