"""Typed wrappers of the experiment-design core (``_design``,
core/sk_api_design.f90, numerics in core/sk_design.f90): choose the
calibration postures that minimise a criterion of the information matrix,
by greedy selection then a modified Fedorov exchange with low-rank updates.

Rows are already whitened (divided by their sigma). Candidate ``c`` (0-based)
owns the rows ``jc[c]`` of shape (nobs, npar); the information matrix of a
chosen set S is ``M = m0 + sum over c in S of jc[c].T @ jc[c]``, on parameters
scaled column by column by ``scale[j] = 1/sqrt(diag(m0 + sum over ALL
candidates)_j)``. The criteria, all lower-is-better:

- ``D``: -log det M (scaled units),
- ``A``: trace M^-1 (scaled units),
- ``task``: trace(Jt M^-1 Jt^T) (scale-invariant: the caller's units).

Every argument is checked here; a bad one raises :class:`DesignError` naming
the argument and the index, e.g. ``jc[3]: row 2 is not finite``.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral

import numpy as np

from ..errors import InputError
from . import _design
from .errors import INFO, call

__all__ = [
    "CRITERIA",
    "DesignError",
    "DesignResult",
    "DiscriminationResult",
    "Weakness",
    "covariance",
    "criterion",
    "discriminate",
    "discrimination",
    "select",
    "weakness",
]

#: criterion name -> the core's code (sk_design: crit_d, crit_a, crit_task)
CRITERIA: dict[str, int] = {"D": 1, "A": 2, "task": 3}

#: argument codes of the design core's errloc[0] (core/sk_design.f90, darg_<name>)
DESIGN_ARGUMENTS: dict[int, str] = {
    1: "jc",
    2: "k",
    3: "criterion",
    4: "m0",
    5: "jt",
    6: "chosen",
    7: "max_passes",
    8: "f",
    9: "jh",
    10: "n0",
    11: "nobs",
}

_HUGE = np.finfo(float).max


class DesignError(InputError):
    """A bad argument of the design core, or a design that does not identify
    the parameters (``column``: the first non-identifiable one, 0-based)."""

    column: int | None = None


@dataclass(frozen=True)
class DesignResult:
    """The selection of :func:`select`.

    ``selected`` (k,) 0-based candidates in the order chosen (greedy order,
    exchanged positions replaced in place); ``value`` the criterion of the
    selection (+inf when M is singular, then ``singular``); ``greedy_value``
    that of the greedy selection before the exchange (+inf if singular);
    ``passes`` exchange passes run, ``swaps`` swaps made; ``scale`` (npar,)
    the column scales; ``path`` (k,) the criterion after each greedy step as
    the low-rank updates carried it (``ridge``: m0 was singular, and until M
    became regular the steps carry the ridged criterion, evaluated from
    scratch); ``scaled``: the value is in scaled units (D, A), not the
    caller's (task). ``value`` and ``greedy_value`` are the updates'
    value, checked against a direct evaluation (Cholesky of M) after the
    greedy steps, at every exchange pass and at the end, and replaced by it
    beyond 1e-9 relative (the updates lose digits when M is ill-conditioned,
    as just after it became regular)."""

    selected: np.ndarray
    value: float
    greedy_value: float
    passes: int
    swaps: int
    scale: np.ndarray
    singular: bool
    criterion: str
    path: np.ndarray
    ridge: bool
    scaled: bool


@dataclass(frozen=True)
class DiscriminationResult:
    """The T-optimal selection of :func:`discriminate`.

    ``selected`` (k,) 0-based candidates; ``value`` the smallest
    noncentrality T over the ordered pairs of hypotheses (existing rows plus
    the selection); ``pairs`` (nh, nh): ``pairs[a, b]`` = ||(I - P_b)(f_a -
    f_b)||^2, the data of hypothesis a fitted by hypothesis b (0 on the
    diagonal); ``greedy_value`` T of the greedy selection; ``passes``,
    ``swaps`` of the exchange."""

    selected: np.ndarray
    value: float
    pairs: np.ndarray
    greedy_value: float
    passes: int
    swaps: int


def _fail(routine: str, what: str) -> DesignError:
    return DesignError(f"{routine}: {what}")


def _count(routine: str, name: str, value: object, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise _fail(routine, f"{name} = {value!r} is not an integer")
    v = int(value)
    if v < lo:
        raise _fail(routine, f"{name} = {v} must be at least {lo}")
    if hi is not None and v > hi:
        raise _fail(routine, f"{name} = {v} exceeds the {hi} candidates")
    return v


def _float_array(routine: str, name: str, a: object) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise _fail(routine, f"{name} is not an array of numbers ({exc})") from None
    return arr


def _jc(routine: str, jc: object) -> np.ndarray:
    a = _float_array(routine, "jc", jc)
    if a.ndim != 3 or 0 in a.shape:
        raise _fail(routine, f"jc must be (ncand, nobs, npar), all >= 1, not shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        c, r = (int(v) for v in np.argwhere(bad)[0][:2])
        raise _fail(routine, f"jc[{c}]: row {r} is not finite")
    return a


def _m0(routine: str, m0: object, npar: int) -> np.ndarray:
    if m0 is None:
        return np.zeros((npar, npar))
    a = _float_array(routine, "m0", m0)
    if a.shape != (npar, npar):
        raise _fail(routine, f"m0 must be ({npar}, {npar}) like jc's parameters, not shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        raise _fail(routine, f"m0: row {int(np.argwhere(bad)[0][0])} is not finite")
    big = float(np.abs(a).max()) if a.size else 0.0
    asym = np.abs(a - a.T)
    if big > 0 and asym.max() > 1e-12 * big:
        i, j = (int(v) for v in np.unravel_index(np.argmax(asym), a.shape))
        raise _fail(routine, f"m0 is not symmetric (m0[{i}, {j}] != m0[{j}, {i}])")
    if big > 0 and np.linalg.eigvalsh(a).min() < -1e-10 * big:
        raise _fail(routine, "m0 is not positive semidefinite (an information matrix is)")
    return a


def _criterion(routine: str, name: object) -> int:
    if not isinstance(name, str) or name not in CRITERIA:
        raise _fail(routine, f"criterion {name!r} is not one of {', '.join(repr(c) for c in CRITERIA)}")
    return CRITERIA[name]


def _jt(routine: str, jt: object, crit: int, npar: int) -> np.ndarray:
    if jt is None:
        if crit == CRITERIA["task"]:
            raise _fail(routine, "criterion 'task' needs jt (the task rows, (nt, npar))")
        return np.zeros((0, npar))
    a = _float_array(routine, "jt", jt)
    if a.ndim != 2 or a.shape[1] != npar or (crit == CRITERIA["task"] and a.shape[0] == 0):
        raise _fail(routine, f"jt must be (nt >= 1, {npar}) like jc's parameters, not shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        raise _fail(routine, f"jt: row {int(np.argwhere(bad)[0][0])} is not finite")
    if crit != CRITERIA["task"]:
        return np.zeros((0, npar))
    return a


def _chosen(routine: str, chosen: object, ncand: int, name: str = "chosen") -> np.ndarray:
    a = np.asarray(chosen)
    if a.ndim != 1 or (a.size and not np.issubdtype(a.dtype, np.integer)):
        raise _fail(routine, f"{name} must be a 1-d array of candidate indices, not {a.dtype} shape {a.shape}")
    seen: dict[int, int] = {}
    for i, c in enumerate(int(v) for v in a):
        if not 0 <= c < ncand:
            raise _fail(routine, f"{name}[{i}] = {c} is not a candidate (0..{ncand - 1})")
        if c in seen:
            raise _fail(routine, f"{name}[{i}] = {c} repeats {name}[{seen[c]}]")
        seen[c] = i
    return a.astype(np.int32) + 1


def _check(routine: str, info: int, errloc: np.ndarray) -> None:
    """An error the core found (the checks above should catch them first)."""
    if int(info) == 0:
        return
    arg = DESIGN_ARGUMENTS.get(int(errloc[0]), "an argument")
    where = f"{arg}[{int(errloc[1]) - 1}]" if int(errloc[1]) > 0 else arg
    text = INFO.get(int(info), (None, f"status {int(info)}"))[1]
    exc = DesignError(f"{routine}: {where}: {text}")
    exc.info = int(info)
    raise exc


def _value(v: float) -> float:
    return float("inf") if v >= _HUGE else float(v)


def select(
    jc: np.ndarray,
    k: int,
    criterion: str,
    m0: np.ndarray | None = None,
    jt: np.ndarray | None = None,
    max_passes: int = 100,
    start: np.ndarray | None = None,
) -> DesignResult:
    """Choose ``k`` of the candidates ``jc`` (ncand, nobs, npar) minimising
    ``criterion`` ('D', 'A' or 'task'; task needs ``jt`` (nt, npar)) given
    the prior information ``m0`` (npar, npar): greedy, then exchange passes
    (at most ``max_passes``) while a swap strictly improves. ``start`` (k,)
    0-based distinct candidates: the exchange starts from them instead of
    the greedy selection (``greedy_value`` and ``path`` are then the start's)."""
    routine = "design.select"
    a = _jc(routine, jc)
    ncand, _, npar = a.shape
    kk = _count(routine, "k", k, 1, ncand)
    crit = _criterion(routine, criterion)
    m = _m0(routine, m0, npar)
    t = _jt(routine, jt, crit, npar)
    passes_max = _count(routine, "max_passes", max_passes, 0)
    st = np.zeros(0, np.int32)
    if start is not None:
        st = _chosen(routine, start, ncand, "start")
        if st.size != kk:
            raise _fail(routine, f"start has {st.size} candidates, not k = {kk}")
    sel, value, gvalue, path, passes, swaps, scale, singular, ridged, info, errloc = call(
        _design.sk_design_select, routine, a.T, kk, crit, m, t.T, passes_max, st
    )
    _check(routine, info, errloc)
    return DesignResult(
        selected=np.asarray(sel, dtype=int) - 1,
        value=_value(value),
        greedy_value=_value(gvalue),
        passes=int(passes),
        swaps=int(swaps),
        scale=np.array(scale),
        singular=bool(singular),
        criterion=str(criterion),
        path=np.array([_value(v) for v in path]),
        ridge=bool(ridged),
        scaled=crit != CRITERIA["task"],
    )


def criterion(
    jc: np.ndarray,
    chosen: np.ndarray,
    criterion: str,
    m0: np.ndarray | None = None,
    jt: np.ndarray | None = None,
) -> float:
    """The criterion of the candidates ``chosen`` (0-based, no repeats)
    evaluated directly (Cholesky of M from scratch, no ridge): +inf when M is
    singular. Same scaling as :func:`select`."""
    routine = "design.criterion"
    a = _jc(routine, jc)
    ncand, _, npar = a.shape
    ch = _chosen(routine, chosen, ncand)
    crit = _criterion(routine, criterion)
    m = _m0(routine, m0, npar)
    t = _jt(routine, jt, crit, npar)
    value, _bad, _scale, info, errloc = call(_design.sk_design_criterion, routine, a.T, ch, crit, m, t.T)
    _check(routine, info, errloc)
    return _value(value)


def covariance(jc: np.ndarray, chosen: np.ndarray, m0: np.ndarray | None = None) -> np.ndarray:
    """M^-1 (npar, npar) of the candidates ``chosen`` in the caller's
    (unscaled) units; raises :class:`DesignError` naming the first parameter
    (0-based column) that the chosen rows and m0 do not identify."""
    routine = "design.covariance"
    a = _jc(routine, jc)
    ncand, _, npar = a.shape
    ch = _chosen(routine, chosen, ncand)
    m = _m0(routine, m0, npar)
    cov, bad, info, errloc = call(_design.sk_design_covariance, routine, a.T, ch, m)
    if int(bad) > 0:
        exc = _fail(
            routine,
            f"parameter {int(bad) - 1} (column {int(bad) - 1} of jc) is not identifiable from the "
            f"{len(ch)} chosen candidates and m0 (it lies in the span of the columns before it)",
        )
        exc.column = int(bad) - 1
        exc.info = int(info)
        raise exc
    _check(routine, info, errloc)
    return np.array(cov)


@dataclass(frozen=True)
class Weakness:
    """What :func:`weakness` finds in a chosen design (core/sk_design_weak.f90).

    ``info`` (npar,) the diagonal of M = m0 + sum of the chosen J_c^T J_c
    (1/info_j: the variance of parameter j if the others were known);
    ``pool`` (npar,) the same over all candidates (and m0): 1/scale^2 of
    :func:`select`, so sqrt(info / pool) is the norm of each column of the
    scaled Jacobian over the chosen rows;
    ``task`` (npar,) the task influence, the sum of squares of jt's column
    j; ``eigenvalues`` (npar,) of the unit-diagonal information, ascending;
    ``nnull`` the dimension of its null space (0: M is regular, as
    :func:`covariance` tests it) and ``null`` (npar, npar) the projector onto
    it: ``null[j, j] > 0`` when parameter j is not identifiable,
    ``null[j, k]`` its share with k."""

    info: np.ndarray
    pool: np.ndarray
    task: np.ndarray
    eigenvalues: np.ndarray
    nnull: int
    null: np.ndarray


def weakness(jc: np.ndarray, chosen: np.ndarray, jt: np.ndarray, m0: np.ndarray | None = None) -> Weakness:
    """Why each parameter of the design ``chosen`` (0-based) stays weak:
    its information, its task influence (``jt`` (nt, npar): the task rows)
    and the null space of the information (:class:`Weakness`)."""
    routine = "design.weakness"
    a = _jc(routine, jc)
    ncand, _, npar = a.shape
    ch = _chosen(routine, chosen, ncand)
    m = _m0(routine, m0, npar)
    t = _jt(routine, jt, CRITERIA["task"], npar)
    info_d, pool, task, ev, nnull, proj, info, errloc = call(_design.sk_design_weakness, routine, a.T, ch, m, t.T)
    _check(routine, info, errloc)
    return Weakness(
        info=np.array(info_d),
        pool=np.array(pool),
        task=np.array(task),
        eigenvalues=np.array(ev),
        nnull=int(nnull),
        null=np.array(proj),
    )


def _rows_finite(routine: str, name: str, a: np.ndarray) -> None:
    bad = ~np.isfinite(a)
    if bad.any():
        raise _fail(routine, f"{name}: row {int(np.argwhere(bad)[0][0])} is not finite")


def _disc_rows(routine: str, f: object, jh: object, n0: object, nobs: object) -> tuple:
    """The checked rows of a discrimination problem: (f, jall: the
    Jacobians side by side, hoff, n0, nobs) (:func:`discriminate`)."""
    fa = _float_array(routine, "f", f)
    if fa.ndim != 2:
        raise _fail(routine, f"f must be (nrow, nh), not shape {fa.shape}")
    nrow, nh = fa.shape
    if nh < 2:
        raise _fail(routine, f"nh = {nh}: discrimination needs at least 2 hypotheses (columns of f)")
    _rows_finite(routine, "f", fa)
    if isinstance(jh, np.ndarray) or not isinstance(jh, (list, tuple)) or len(jh) != nh:
        raise _fail(routine, f"jh must be a list of {nh} Jacobians (one per column of f)")
    blocks = []
    for h, j in enumerate(jh):
        a = _float_array(routine, f"jh[{h}]", j)
        if a.ndim != 2 or a.shape[0] != nrow or a.shape[1] < 1:
            raise _fail(routine, f"jh[{h}] must be ({nrow}, p >= 1) like f's rows, not shape {a.shape}")
        _rows_finite(routine, f"jh[{h}]", a)
        blocks.append(a)
    n0v = _count(routine, "n0", n0, 0)
    if n0v > nrow:
        raise _fail(routine, f"n0 = {n0v} exceeds the {nrow} rows of f")
    nobsv = _count(routine, "nobs", nobs, 1)
    if (nrow - n0v) % nobs or nrow == n0v:
        raise _fail(routine, f"the {nrow - n0v} candidate rows (nrow - n0) are not blocks of nobs = {nobsv}")
    hoff = np.concatenate([[0], np.cumsum([b.shape[1] for b in blocks])]).astype(np.int32)
    return fa, np.asfortranarray(np.hstack(blocks)), hoff, n0v, nobsv


def discrimination(
    f: np.ndarray, jh: list[np.ndarray], n0: int, nobs: int, chosen: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Evaluate a discrimination design as :func:`discriminate` would:
    with the first ``n0`` rows and the candidates ``chosen`` (0-based, may
    be empty), (pairs (nh, nh) their noncentralities, ``pairs[a, b]`` the
    data of a fitted by b; per candidate (ncand,) the smallest
    noncentrality after adding that candidate alone, NaN for the chosen)."""
    routine = "design.discrimination"
    fa, jall, hoff, n0v, nobsv = _disc_rows(routine, f, jh, n0, nobs)
    ncand = (fa.shape[0] - n0v) // nobsv
    ch = _chosen(routine, chosen, ncand)
    pairs, tc, info, errloc = call(_design.sk_design_disc_evaluate, routine, ncand, fa, jall, hoff, n0v, nobsv, ch)
    _check(routine, info, errloc)
    tc = np.array(tc)
    tc[ch - 1] = np.nan
    return np.array(pairs), tc


def discriminate(
    f: np.ndarray,
    jh: list[np.ndarray],
    n0: int,
    nobs: int,
    k: int,
    max_passes: int = 100,
) -> DiscriminationResult:
    """T-optimal design: choose ``k`` candidates maximising the smallest
    noncentrality between ``nh >= 2`` hypotheses. ``f`` (nrow, nh): whitened
    predictions of each hypothesis (fitted to the data so far) at all rows,
    the first ``n0`` the existing data, then ncand blocks of ``nobs`` rows,
    one per candidate; ``jh``: nh arrays (nrow, p_h >= 1), the whitened
    Jacobian of each hypothesis' parameters at all rows."""
    routine = "design.discriminate"
    fa, jall, hoff, n0v, nobsv = _disc_rows(routine, f, jh, n0, nobs)
    nrow = fa.shape[0]
    kk = _count(routine, "k", k, 1, (nrow - n0v) // nobsv)
    passes_max = _count(routine, "max_passes", max_passes, 0)
    sel, value, gvalue, pairs, passes, swaps, info, errloc = call(
        _design.sk_design_discriminate, routine, fa, jall, hoff, n0v, nobsv, kk, passes_max
    )
    _check(routine, info, errloc)
    return DiscriminationResult(
        selected=np.asarray(sel, dtype=int) - 1,
        value=float(value),
        pairs=np.array(pairs),
        greedy_value=float(gvalue),
        passes=int(passes),
        swaps=int(swaps),
    )
