"""The one TOML writer of stiffkit (model files of both data kinds, the
[[effect]] tables diagnose proposes): tomli-w on plain Python values.

Every number is written exactly (tomli-w writes a float as its ``repr``,
which reads back as the same double), numpy scalars and arrays become
Python numbers and lists, and what a reader of stiffkit would refuse is
refused here, naming the key: a non-finite number, a value that is not a
number, string, boolean, list or table. Comments (``header``) go first,
as ``#`` lines.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import tomli_w

from ..errors import InputError

__all__ = ["dumps", "effect_tables", "effect_toml", "plain"]


def plain(v: object, key: str = "value") -> object:
    """``v`` with numpy scalars/arrays and tuples turned into Python numbers
    and lists; raises InputError naming ``key`` for a non-finite number or a
    value TOML cannot hold."""
    if isinstance(v, dict):
        return {str(k): plain(x, f"{key}.{k}" if key else str(k)) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [plain(x, f"{key}[{i}]") for i, x in enumerate(v)]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if not math.isfinite(x):
            raise InputError(f"cannot write the non-finite value {x} of {key} to a TOML file")
        return x
    if isinstance(v, str):
        return v
    raise InputError(f"cannot write {key}, a value of type {type(v).__name__}, to a TOML file")


def dumps(doc: dict, header: str = "") -> str:
    """The TOML text of ``doc`` (tables, arrays of tables), after ``header``
    (comment lines; a line without ``#`` gets one)."""
    head = ""
    if header:
        head = "".join((ln if ln.startswith("#") else f"# {ln}") + "\n" for ln in header.rstrip("\n").split("\n"))
    return head + tomli_w.dumps(plain(doc, ""))


def effect_tables(effects: Iterable[dict]) -> str:
    """[[effect]] tables, each after an empty line (appendable to a model file)."""
    return "".join("\n" + effect_toml(e) + "\n" for e in effects)


def effect_toml(effect: dict) -> str:
    """One ``[[effect]]`` table (the form diagnose proposes and a model file
    holds), without a final newline."""
    table = plain(effect, "effect")
    for k, v in table.items():
        if isinstance(v, dict):  # tomli-w would write it as a [k] table, outside the [[effect]]
            raise InputError(f"cannot write effect.{k}, a table, inside an [[effect]] table")
    # each table by itself: tomli-w writes a short array of tables inline (effect = [{...}])
    return ("[[effect]]\n" + tomli_w.dumps(table)).rstrip("\n")
