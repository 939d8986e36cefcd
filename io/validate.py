"""One check per input kind: numbers with their units and ranges, arrays
handed to the Python API, 6x6 matrices, output paths and JSON documents.

Every stage checks what a user gives through these functions, so that a
check is written once and every failure reads the same: one line naming
where the value came from (file, row or key, option, argument), the value
and what it must be, raised as :class:`~stiffkit.errors.InputError` (the
command line turns it into exit status 2).

Units. Files and arguments are SI (m, N, N m, rad, Pa). A value that is
valid but implausible for its unit (a robot 1000 m long, a joint at 90 rad,
E = 2e5 Pa) is most likely a unit slip: it is accepted with a
:class:`~stiffkit.errors.PlausibilityWarning` naming the value, the unit it
looks like and the fix. A value so large or small that the numerics would
overflow (``|value|`` beyond the quantity's ``limit``) is an error.
"""

from __future__ import annotations

import math
import numbers
import os
import re
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, PlausibilityWarning
from .files import check_output, json_ready

__all__ = [
    "shown",
    "Quantity",
    "QUANTITIES",
    "quantity",
    "number",
    "count",
    "array",
    "plausible",
    "plausible_array",
    "symmetric6",
    "json_ready",
    "output_path",
    "warn",
]


@dataclass(frozen=True)
class Quantity:
    """A physical quantity as stiffkit's files give it (SI).

    ``limit``: largest magnitude accepted at all (beyond it squares and
    products overflow, or the value cannot be meant); ``plausible``: the
    range of magnitudes (non-zero values) that real robots and links have;
    ``slips``: units a value is often given in by mistake, with the factor
    that turns such a number into SI (e.g. ("mm", 1e-3))."""

    name: str
    unit: str
    limit: float
    plausible: tuple[float, float] = (0.0, math.inf)
    slips: tuple[tuple[str, float], ...] = ()

    @property
    def label(self) -> str:
        """The quantity in words ("joint compliance"; "E" is Young's modulus)."""
        special = {
            "E": "Young's modulus E",
            "matrix6": "6x6 matrix element",
            "sigma_position": "position noise (sigma)",
            "sigma_rotation": "rotation noise (sigma)",
        }
        return special.get(self.name, self.name.replace("_", " "))


_MM = (("mm", 1e-3),)
#: the quantities of stiffkit's inputs; the names are used by every reader
QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        # coordinates of points (robot frames, nodes, reference points): a
        # part or robot bigger than 50 m is a slip (mm most likely)
        Quantity("position", "m", 1e4, (0.0, 50.0), _MM),
        # a length that is a size (mesh size, lscale, compensator arms)
        Quantity("length", "m", 1e4, (1e-5, 50.0), _MM),
        # FEA node displacements; measured deflections of a robot
        Quantity("displacement", "m", 1e2, (0.0, 0.1), _MM),
        Quantity("deflection", "m", 1e2, (0.0, 0.1), _MM),
        # joint positions: beyond one turn it is degrees
        Quantity("angle", "rad", 1e4, (0.0, 2 * math.pi + 1e-6), (("deg", math.pi / 180),)),
        # small rotations of a measured frame, rotation vectors of a deflection
        Quantity("rotation", "rad", 1e2, (0.0, 0.2), (("deg", math.pi / 180),)),
        Quantity("force", "N", 1e9, (0.0, 1e7)),
        Quantity("moment", "N m", 1e9, (0.0, 1e6), (("N mm", 1e-3),)),
        # noise of a measured coordinate (a tracker: 1e-6 .. 1e-4 m)
        Quantity("sigma_position", "m", 1.0, (1e-9, 1e-3), (("mm", 1e-3), ("um", 1e-6))),
        Quantity("sigma_rotation", "rad", 1.0, (1e-10, 1e-2)),
        # Young's modulus: foams to diamond; N/mm^2 (MPa) and GPa are the slips
        Quantity("E", "Pa", 1e13, (5e7, 1.5e12), (("N/mm^2 (MPa)", 1e6), ("GPa", 1e9))),
        Quantity("density", "kg/m^3", 1e6, (50.0, 3e4), (("g/cm^3", 1e3), ("t/mm^3", 1e12))),
        Quantity("joint_compliance", "rad/(N m)", 1.0, (1e-13, 1e-2)),
        Quantity("linear_compliance", "m/N", 1.0, (1e-14, 1e-2), (("mm/N", 1e-3),)),
        Quantity("spring_stiffness", "N/m", 1e15, (1e-3, 1e12), (("N/mm", 1e3),)),
        # the elements of a 6x6 compliance or stiffness (SI): only overflow is refused
        Quantity("matrix6", "SI", 1e20),
        Quantity("timeout", "s", 1e7, (1.0, 1e6)),
    )
}


def quantity(name: str | Quantity | None) -> Quantity | None:
    if name is None or isinstance(name, Quantity):
        return name
    return QUANTITIES[name]


def _fmt(v: object) -> str:
    if isinstance(v, bool) or v is None:
        return repr(v)
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return f"{float(v):g}"
    return repr(v)


def _unit(q: Quantity | None, unit: str | None) -> str:
    u = unit if unit is not None else (q.unit if q is not None and q.unit != "SI" else "")
    return f" {u}" if u else ""


def _range_text(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    if lo == 0 and hi is None:
        return "positive" if lo_open else ">= 0"
    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{_fmt(lo)}, {_fmt(hi)}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {_fmt(lo)}"
    return f"{'<' if hi_open else '<='} {_fmt(hi)}"


_PLAIN = re.compile(r"[A-Za-z0-9_.+\-/]+")


def shown(v: object) -> str:
    """A user's word as a message shows it: as it is when it is a plain name
    (letters, digits, _ . + - /), else quoted with escapes (repr), so that a
    newline or a control character never breaks a one-line message."""
    return v if isinstance(v, str) and _PLAIN.fullmatch(v) else repr(v)


def suggest(word: object, choices: Iterable[str]) -> str:
    """ " (did you mean 'x'?)" for the choice closest to a mistyped word, or ""."""
    import difflib

    close = difflib.get_close_matches(str(word), list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def known_keys(table: dict, known: Iterable[str], what: str, error: type[InputError] = InputError) -> None:
    """Refuse keys of ``table`` outside ``known``: "{what} 'k1', 'k2' (did
    you mean ..?); known: ..." (a typo is an error, not a silent default)."""
    known = list(known)
    unknown = sorted(set(table) - set(known))
    if unknown:
        names = ", ".join(map(shown, unknown))
        raise error(f"{what} {names}{suggest(unknown[0], known)}; known: {', '.join(known)}")


def warn(message: str, stacklevel: int = 3, key: object = None) -> None:
    """A :class:`PlausibilityWarning` (the command line prints it as one
    line); ``key`` identifies the finding (e.g. (quantity, value)) so that a
    value checked twice on its way (option, then API) is reported once."""
    w = PlausibilityWarning(message)
    w.key = key
    warnings.warn(w, stacklevel=stacklevel)


def _an(word: str) -> str:
    return ("an " if word[:1].lower() in "aeiou" else "a ") + word


def _implausible(v: float, q: Quantity, many: bool = False) -> str | None:
    """Why |v| is implausible for q (with the likely slip and the fix), or
    None; ``many``: v is the extreme of an array (the fix is a factor)."""
    a = abs(float(v))
    lo, hi = q.plausible
    if a == 0 or lo <= a <= hi:
        return None
    side = "large" if a > hi else "small"
    unit = _unit(q, None)
    for slip, factor in q.slips:
        s = a * factor
        if lo <= s <= hi and ((side == "large") == (factor < 1)):
            fix = f"multiply by {factor:g}" if many else f"give {math.copysign(s, v):g}{unit} instead"
            return f"is implausibly {side} for {_an(q.label)} in{unit}; it looks like {slip}: {fix}"
    expect = f"{lo:g} to {hi:g}" if hi < math.inf else f"at least {lo:g}"
    return f"is implausibly {side} for {_an(q.label)} in{unit} (expected {expect}{unit}); check the unit"


def plausible(v: float, name: str, q: str | Quantity | None) -> None:
    """Warn when ``v`` is implausible for its quantity (see the module docstring)."""
    q = quantity(q)
    if q is None:
        return
    why = _implausible(v, q)
    if why:
        warn(f"{name} = {_fmt(v)}{_unit(q, None)} {why}", stacklevel=4, key=(q.name, float(v)))


def number(
    value: object,
    name: str,
    q: str | Quantity | None = None,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    integer: bool = False,
    unit: str | None = None,
    check_plausible: bool = True,
) -> float:
    """A finite number (int or float, not a bool or a string) within its range.

    ``name`` says where the value came from (e.g. "LINK.toml: [material] E"
    or "--sigma"); ``q`` names the quantity (its unit, hard limit and
    plausible range, see QUANTITIES); ``lo``/``hi`` bound the value
    (``*_open``: strictly). Raises InputError naming ``name`` and the value;
    warns (PlausibilityWarning) when it is implausible for its unit.
    """
    qq = quantity(q)
    u = _unit(qq, unit)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        kind = "an integer" if integer else "a number"
        raise InputError(f"{name} = {value!r} must be {kind}{u.replace(' ', ' in ', 1) if u else ''}")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond double precision
        raise InputError(f"{name} = {str(value)[:12]}... is out of range (beyond double precision)") from None
    if integer and not v.is_integer():
        raise InputError(f"{name} = {_fmt(value)} must be an integer")
    if not math.isfinite(v):
        raise InputError(f"{name} = {value} must be a finite number")
    if qq is not None and abs(v) > qq.limit:
        raise InputError(
            f"{name} = {_fmt(value)}{u} is out of range for {_an(qq.label)} "
            f"(|value| <= {qq.limit:g}{u}); check the unit"
        )
    bad = (lo is not None and (v < lo or (lo_open and v == lo))) or (
        hi is not None and (v > hi or (hi_open and v == hi))
    )
    if bad:
        raise InputError(f"{name} = {_fmt(value)}{u} must be {_range_text(lo, hi, lo_open, hi_open)}")
    if check_plausible and qq is not None:
        why = _implausible(v, qq)
        if why:
            warn(f"{name} = {_fmt(value)}{u} {why}", stacklevel=3, key=(qq.name, v))
    return int(v) if integer else v


def count(value: object, name: str, lo: int = 1, hi: int | None = None) -> int:
    """An integer count in [lo, hi] (e.g. a number of postures)."""
    return int(number(value, name, lo=lo, hi=hi, integer=True))


def _first_bad(mask: np.ndarray) -> tuple:
    idx = np.argwhere(mask)[0]
    return tuple(int(i) for i in idx)


def array(
    value: object,
    name: str,
    shape: tuple | None = None,
    q: str | Quantity | None = None,
    *,
    min_rows: int | None = None,
    check_plausible: bool = True,
) -> np.ndarray:
    """A float array from what an API user passes (lists, tuples, arrays).

    ``shape`` may hold None for any size (e.g. (None, 3) for points); a
    leading dimension of a 1-D input is not added. Raises InputError naming
    ``name`` for text, ragged or complex input, a wrong shape, NaN/Inf (with
    the index of the first) and magnitudes beyond the quantity's limit; warns
    when the largest magnitude is implausible for the quantity.
    """
    qq = quantity(q)
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nested lists
        raise InputError(f"{name} must be an array of numbers; got rows of different lengths") from None
    if raw.dtype.kind in "biuf" and raw.dtype.kind != "b":
        a = raw.astype(float, copy=False)
    elif raw.dtype.kind == "O":
        try:
            a = np.array(value, dtype=float)
        except OverflowError:
            raise InputError(f"{name} holds an integer beyond double precision") from None
        except (TypeError, ValueError):
            raise InputError(f"{name} must be an array of numbers; it holds {_kinds(raw)}") from None
    else:
        what = {"b": "booleans", "c": "complex numbers", "U": "text", "S": "bytes"}.get(raw.dtype.kind, str(raw.dtype))
        raise InputError(f"{name} must be an array of numbers; got {what}")
    if shape is not None:
        ok = a.ndim == len(shape) and all(s is None or s == n for s, n in zip(shape, a.shape))
        if not ok:
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            raise InputError(f"{name} must have shape {want}, got {a.shape}")
    if min_rows is not None and (a.ndim == 0 or a.shape[0] < min_rows):
        raise InputError(f"{name}: needs at least {min_rows} rows, got {0 if a.ndim == 0 else a.shape[0]}")
    fin = np.isfinite(a)
    if not fin.all():
        i = _first_bad(~fin)
        raise InputError(f"{name}{list(i) if i else ''} is {a[i]}: NaN or Inf where every value must be finite")
    if qq is not None and a.size:
        big = np.abs(a) > qq.limit
        if big.any():
            i = _first_bad(big)
            raise InputError(
                f"{name}{list(i) if i else ''} = {a[i]:g}{_unit(qq, None)} is out of range for "
                f"{_an(qq.label)} (|value| <= {qq.limit:g}{_unit(qq, None)}); check the unit"
            )
        if check_plausible:
            plausible_array(a, name, qq)
    return a


def _kinds(raw: np.ndarray) -> str:
    kinds = sorted({type(x).__name__ for x in raw.ravel()[:1000]})
    return ", ".join(kinds)


def plausible_array(a: object, name: str, q: str | Quantity, where: str = "") -> None:
    """One warning when the largest magnitude in ``a`` is implausible for
    the quantity (``where`` may name the row of that value)."""
    qq = quantity(q)
    a = np.asarray(a, dtype=float)
    if not a.size:
        return
    nz = np.abs(a[np.isfinite(a)])
    nz = nz[nz > 0]
    if not nz.size:
        return
    lo, hi = qq.plausible
    v = float(nz.max()) if nz.max() > hi else float(nz.min())
    why = _implausible(v, qq, many=True)
    if why:
        warn(
            f"{name}: |value| {'up to' if v >= hi else 'down to'} {_fmt(v)}{_unit(qq, None)}{where} {why}", stacklevel=4
        )


def symmetric6(
    m: np.ndarray, name: str, silent: float = 1e-9, error: float = 0.1, noise: np.ndarray | None = None
) -> tuple[np.ndarray, float]:
    """(C + C^T)/2 of a 6x6 compliance or stiffness, and its asymmetry.

    The asymmetry is max |c_ij - c_ji| / sqrt(|c_ii c_jj|) (the measure the
    field fit reports). Up to ``silent`` (or, when ``noise`` gives the
    standard deviation of every element, where each |c_ij - c_ji| is within
    three standard deviations of their difference) the matrix is
    symmetrised silently; up to ``error`` with a warning naming the pair;
    beyond, it is not a compliance: InputError.
    """
    m = np.asarray(m, dtype=float)
    d = np.sqrt(np.abs(np.diag(m)))
    scale = np.outer(d, d)
    diff = np.abs(m - m.T)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(scale > 0, diff / scale, np.where(diff > 0, np.inf, 0.0))
    asym = float(rel.max())
    i, j = np.unravel_index(int(np.argmax(rel)), rel.shape)
    within_noise = False
    if noise is not None:
        s = np.asarray(noise, dtype=float)
        tol = 3.0 * np.sqrt(s**2 + s.T**2)
        within_noise = bool(np.all(diff <= tol))
    if asym > error:
        raise InputError(
            f"{name} is not symmetric: c{i + 1}{j + 1} = {m[i, j]:.4g} but c{j + 1}{i + 1} = {m[j, i]:.4g} "
            f"(asymmetry {asym:.3g}; a compliance or stiffness is symmetric)"
        )
    if asym > silent and not within_noise:
        warn(
            f"{name}: asymmetry {asym:.3g} at c{i + 1}{j + 1} ({m[i, j]:.4g} vs {m[j, i]:.4g}) is above the "
            f"{'noise of its elements' if noise is not None else 'round-off'}; using (C + C^T)/2",
            stacklevel=3,
        )
    return 0.5 * (m + m.T), asym


def output_path(
    path: Path | str, what: str, inputs: Iterable[Path | str | None] = (), suffixes: tuple[str, ...] | None = None
) -> Path:
    """The path of an output file, checked before any work is done: not a
    folder, not one of the ``inputs`` (overwriting what is being read), and
    with one of ``suffixes`` when given (e.g. (".png", ".svg", ".pdf")); not
    a block device or socket, and its folder writable (io.files.check_output)."""
    p = Path(path)
    if str(path).strip() == "":
        raise InputError(f"{what}: empty file name")
    if p.is_dir():
        raise InputError(f"{what} {p}: is a folder; give a file name")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise InputError(f"{what} {p}: the file name must end in one of {', '.join(suffixes)}")
    for src in inputs:
        if src is None:
            continue
        s = Path(src)
        same = False
        try:
            same = p.exists() and s.exists() and os.path.samefile(p, s)
        except OSError:
            same = False
        if same or p.resolve() == s.resolve():
            raise InputError(f"{what} {p}: is an input file of this command; choose another output name")
    return check_output(p, what)


def distinct_outputs(items: dict) -> None:
    """InputError when two output options name the same file ({option: path or None})."""
    seen: dict[Path, str] = {}
    for opt, path in items.items():
        if not path:
            continue
        key = Path(path).resolve()
        if key in seen:
            raise InputError(f"{opt} {path}: the same file as {seen[key]}; give each output its own name")
        seen[key] = opt
