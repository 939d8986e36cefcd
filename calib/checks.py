"""Data checks before the model: gross errors, outlying configurations,
unit slips, and a robust (IRLS) fit that is not pulled by them.

The functions take generic inputs so that any calibration can use them
(relative deflections under known loads, absolute tracker positions under
gravity, ...), without knowing how the residuals were made:

- ``residuals`` (n, k): one row per measured point, k coordinates, either
  already standardised (sigma = 1) or with ``sigma`` (a scalar or one value
  per coordinate);
- ``labels`` (n,): the configuration (posture) of each row;
- ``measured``, ``predicted`` (n, k): for the unit checks, what was
  measured and what the model predicts (the model's scale); optional
  ``load`` (n,): the load magnitude of each row;
- a linear(ised) least-squares problem ``A x ~ b`` whose observations
  belong to rows (``obs_rows``), for the robust fit.

The statistics: a row's squared standardised residual is chi-square with
k degrees of freedom under the model; a row is a gross error when its tail
probability is below alpha / n (Bonferroni over the rows), judged against
the larger of the declared sigma and a robust scale of all residuals, so
that a model error that spreads over every row is not mistaken for a few
bad rows, and only when it stands out from the other rows of its own
configuration (a missing effect raises all the rows of the postures where
it acts; a misread marker raises one row). A configuration is a unit slip when its measured rows are, in
least squares, a known factor (1e3: mm for m; 1e6: um; 1e2: cm; 180/pi:
degrees for radians) times the model's prediction and dividing by that
factor removes most of its misfit.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from .._core import calib as core
from ..errors import InputError

__all__ = [
    "UNIT_FACTORS",
    "RowFlag",
    "ConfigFlag",
    "UnitSlip",
    "row_statistics",
    "robust_sigma",
    "row_weights",
    "irls",
    "outlier_rows",
    "outlying_configs",
    "unit_slips",
    "angle_units",
    "copies",
    "copies_message",
    "drop_copies",
    "cannot_judge",
]

#: (factor, what it means, the fix) for quantities in metres
LENGTH_FACTORS = (
    (1e3, "recorded in mm instead of m", "divide them by 1000"),
    (1e6, "recorded in um instead of m", "divide them by 1e6"),
    (1e2, "recorded in cm instead of m", "divide them by 100"),
)
#: for quantities in radians
ANGLE_FACTORS = ((180.0 / math.pi, "recorded in degrees instead of radians", "multiply them by pi/180"),)
UNIT_FACTORS = LENGTH_FACTORS + ANGLE_FACTORS
#: a gross error stands out from the other rows of its configuration by this factor
LOCAL_RATIO = 5.0
#: flagged rows of one load whose residual vectors agree this well share a cause
COHERENT_COS = 0.9


@dataclass
class RowFlag:
    """A row whose residual is far outside the noise."""

    row: int  # 0-based index
    config: str
    statistic: float  # squared standardised residual over the robust scale^2 (chi-square, k dof)
    log10_p: float  # its tail probability (one row)
    norm_sigma: float  # |residual| / sigma

    def to_json(self, line: int | None = None) -> dict:
        d = {
            "row": self.row,
            "config": self.config,
            "standardised_residual": self.norm_sigma,
            "log10_p": self.log10_p,
        }
        if line is not None:
            d["line"] = int(line)
        return d


@dataclass
class ConfigFlag:
    """A configuration whose rows are, together, far outside the noise."""

    config: str
    rows: list[int]
    statistic: float
    dof: int
    log10_p: float

    def to_json(self) -> dict:
        return {
            "config": self.config,
            "rows": self.rows,
            "statistic": self.statistic,
            "dof": self.dof,
            "log10_p": self.log10_p,
        }


@dataclass
class UnitSlip:
    """A configuration whose measurements are a unit factor off the model."""

    config: str
    rows: list[int]
    ratio: float  # least-squares measured / predicted
    factor: float
    quantity: str  # "measured" or "load"
    meaning: str
    fix: str
    misfit_removed: float  # fraction of the configuration's misfit removed by the fix
    extra: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {
            "config": self.config,
            "rows": self.rows,
            "ratio": self.ratio,
            "factor": self.factor,
            "quantity": self.quantity,
            "meaning": self.meaning,
            "fix": self.fix,
            "misfit_removed": self.misfit_removed,
            **self.extra,
        }


def _sig(sigma: npt.ArrayLike | None, k: int) -> np.ndarray:
    s = np.broadcast_to(np.asarray(1.0 if sigma is None else sigma, float), (k,))
    if not np.all(s > 0):
        raise ValueError("sigma must be positive")
    return s


def row_statistics(residuals: npt.ArrayLike, sigma: npt.ArrayLike | None = None) -> np.ndarray:
    """Squared standardised residual of every row (n,): sum_k (r_ik / sigma_k)^2."""
    r = np.atleast_2d(np.asarray(residuals, float))
    return np.sum((r / _sig(sigma, r.shape[1])) ** 2, axis=1)


def robust_sigma(residuals: npt.ArrayLike, sigma: npt.ArrayLike | None = None) -> float:
    """Robust noise scale of standardised residuals (1.4826 x the median
    absolute coordinate): about 1 when the rows are noise at sigma, larger
    when a model error spreads over the rows; not moved by a few gross
    errors."""
    r = np.atleast_2d(np.asarray(residuals, float)) / _sig(sigma, np.shape(residuals)[-1])
    return float(1.4826 * np.median(np.abs(r))) if r.size else 1.0


def _chi2_quantile(p: float, k: float) -> float:
    """Wilson-Hilferty approximation of the chi-square p-quantile."""
    z = math.sqrt(2.0) * _erfinv(2.0 * p - 1.0)
    a = 2.0 / (9.0 * k)
    return k * max(1.0 - a + z * math.sqrt(a), 0.0) ** 3


def _erfinv(y: float) -> float:
    # Newton on erf, started at a rational guess: enough for tuning constants
    x = 0.0 if y == 0 else math.copysign(math.sqrt(-math.log((1 - abs(y)) / 2)), y)
    for _ in range(60):
        err = math.erf(x) - y
        x -= err / (2.0 / math.sqrt(math.pi) * math.exp(-x * x))
        if abs(err) < 1e-15:
            break
    return x


def row_weights(stat: npt.ArrayLike, k: int, kind: str = "huber", c: float | None = None) -> np.ndarray:
    """IRLS weights of rows from their squared standardised residuals.

    d = sqrt(stat) is the row's residual norm in sigma; c defaults to the
    95 % point of the noise (sqrt of the chi-square(k) 0.95 quantile).
    huber: 1 for d <= c, c / d beyond (bounded influence, convex);
    cauchy: 1 / (1 + (d / c)^2) (redescending: gross errors fade out)."""
    d = np.sqrt(np.maximum(np.asarray(stat, float), 0.0))
    c = math.sqrt(_chi2_quantile(0.95, k)) if c is None else float(c)
    if kind == "huber":
        return np.where(d <= c, 1.0, c / np.maximum(d, 1e-300))
    if kind == "cauchy":
        return 1.0 / (1.0 + (d / c) ** 2)
    raise ValueError(f"unknown robust weight {kind!r}; choose huber or cauchy")


def irls(
    A: np.ndarray,
    b: np.ndarray,
    obs_rows: npt.ArrayLike,
    n_rows: int,
    kind: str = "huber",
    max_iter: int = 30,
    rcond: float = 1e-10,
    tol: float = 1e-6,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Robust least squares A x ~ b (observations already divided by their
    sigma) by iteratively reweighted least squares around the core's
    weighted least squares (one weight per row, shared by its
    observations): Huber from the plain solution, then Cauchy from the
    Huber solution when ``kind`` is "cauchy".

    Returns (x, weights (n_rows,), residual b - A x (n_obs,), scale) where
    scale is the robust sigma (in units of the given sigma) of the final
    residual."""
    A = np.asarray(A, float)
    b = np.asarray(b, float)
    obs_rows = np.asarray(obs_rows)
    k = max(1, int(round(A.shape[0] / max(n_rows, 1))))
    if A.shape[1] == 0:
        return np.zeros(0), np.ones(n_rows), b.copy(), 1.0
    x = core.wls(A, b, rcond, 1e-6)[0]
    w = np.ones(n_rows)
    for stage in ("huber", "cauchy") if kind == "cauchy" else ("huber",):
        for _ in range(max_iter):
            e = b - A @ x
            stat = np.bincount(obs_rows, weights=e * e, minlength=n_rows)
            scale = max(1.0, robust_sigma(e))
            w_new = row_weights(stat / scale**2, k, stage)
            sw = np.sqrt(w_new)[obs_rows]
            x_new = core.wls(A * sw[:, None], b * sw, rcond, 1e-6)[0]
            done = np.linalg.norm(x_new - x) <= tol * max(np.linalg.norm(x_new), 1e-300) or np.allclose(
                w_new, w, rtol=0.0, atol=1e-3
            )
            x, w = x_new, w_new
            if done:
                break
    e = b - A @ x
    return x, w, e, max(1.0, robust_sigma(e))


def outlier_rows(
    residuals: npt.ArrayLike,
    sigma: npt.ArrayLike | None = None,
    labels: Sequence[object] | None = None,
    alpha: float = 0.01,
    scale: float | None = None,
    local_ratio: float = LOCAL_RATIO,
    groups: Sequence[object] | None = None,
) -> list[RowFlag]:
    """Rows whose residual is a gross error. Largest first.

    A row is flagged when (1) the chi-square(k) tail of its squared
    standardised residual, divided by ``scale``^2 (default: the larger of 1
    and the residuals' robust scale, so that a model error spread over all
    rows is not called a gross error), is below alpha / n (Bonferroni over
    the n rows), and (2) with ``labels``, it stands out from its own
    configuration: its residual norm exceeds ``local_ratio`` times the
    larger of 1 and the median norm of the rows of that configuration
    (a missing effect raises every row of the postures where it acts; a
    misread marker raises one row)."""
    r = np.atleast_2d(np.asarray(residuals, float))
    n, k = r.shape
    stat_raw = row_statistics(r, sigma)
    norm = np.sqrt(stat_raw)
    scale = max(1.0, robust_sigma(r, sigma)) if scale is None else float(scale)
    stat = stat_raw / scale**2
    crit = math.log(alpha / max(n, 1))
    local = np.ones(n)
    if labels is not None:
        for rows in _groups(labels).values():
            # the configuration's median (with 3 rows or more one row cannot move it far)
            local[rows] = scale if len(rows) < 3 else max(1.0, float(np.median(norm[rows])))
    cand = []
    for i in np.argsort(-stat):
        lp = core.chi2_logsf(stat[i], k)
        if lp >= crit:
            break
        if norm[i] > local_ratio * local[i]:
            cand.append((int(i), lp))
    coherent = set()
    if groups is not None:
        flagged = [i for i, _ in cand]
        by_group: dict[str, list[int]] = {}
        for i in flagged:
            by_group.setdefault(str(groups[i]), []).append(i)
        for rows in by_group.values():
            for a in rows:
                for b in rows:
                    if a < b:
                        ra, rb = r[a], r[b]
                        na, nb = np.linalg.norm(ra), np.linalg.norm(rb)
                        if na > 0 and nb > 0 and ra @ rb / (na * nb) >= COHERENT_COS and max(na, nb) <= 2 * min(na, nb):
                            coherent |= {a, b}
    out = []
    for i, lp in cand:
        if i in coherent:
            continue
        out.append(
            RowFlag(
                row=int(i),
                config=str(labels[i]) if labels is not None else str(i),
                statistic=float(stat[i]),
                log10_p=lp / math.log(10),
                norm_sigma=float(norm[i]),
            )
        )
    return out


def _groups(labels: Iterable[object]) -> dict[str, list[int]]:
    out: dict[str, list[int]] = {}
    for i, c in enumerate(labels):
        out.setdefault(str(c), []).append(i)
    return out


def outlying_configs(
    residuals: npt.ArrayLike,
    labels: Iterable[object],
    sigma: npt.ArrayLike | None = None,
    alpha: float = 0.01,
    scale: float | None = None,
    skip: Collection[int] = (),
) -> list[ConfigFlag]:
    """Configurations whose rows together are far outside the noise: the sum
    of their squared standardised residuals against chi-square(k n_c),
    Bonferroni over the configurations (rows in ``skip`` left out)."""
    r = np.atleast_2d(np.asarray(residuals, float))
    k = r.shape[1]
    stat = row_statistics(r, sigma)
    scale = max(1.0, robust_sigma(r, sigma)) if scale is None else float(scale)
    stat = stat / scale**2
    groups = _groups(labels)
    skip = set(skip)
    crit = math.log(alpha / max(len(groups), 1))
    out = []
    for cfg, rows in groups.items():
        rows = [i for i in rows if i not in skip]
        if not rows:
            continue
        s = float(stat[rows].sum())
        lp = core.chi2_logsf(s, k * len(rows))
        if lp < crit:
            out.append(ConfigFlag(cfg, rows, s, k * len(rows), lp / math.log(10)))
    out.sort(key=lambda f: f.log10_p)
    return out


def unit_slips(
    measured: npt.ArrayLike,
    predicted: npt.ArrayLike,
    labels: Iterable[object],
    sigma: npt.ArrayLike | None = None,
    load: npt.ArrayLike | None = None,
    factors: Iterable[tuple[float, str, str]] = LENGTH_FACTORS,
    tol: float = 0.15,
    min_removed: float = 0.9,
) -> list[UnitSlip]:
    """Configurations whose measurements are a unit factor off the model's
    prediction (the model's scale).

    For each configuration, s = <m, p> / <p, p> over its rows; when
    |log10(s / F)| < tol for a factor F of ``factors`` and m / F fits p
    with at most (1 - min_removed) of the misfit of m, the configuration
    is a unit slip. With ``load`` (n,) the blame goes to the load when the
    configuration's loads are 1/F of the others' (then the prediction, not
    the measurement, is F too small). The predicted rows should come from
    a fit that is not pulled by the slipped rows (a robust fit).
    """
    m = np.atleast_2d(np.asarray(measured, float))
    p = np.atleast_2d(np.asarray(predicted, float))
    sig = _sig(sigma, m.shape[1])
    groups = _groups(labels)
    load = None if load is None else np.asarray(load, float)
    med_load = float(np.median(load)) if load is not None and np.any(load > 0) else None
    out = []
    for cfg, rows in groups.items():
        mg, pg = m[rows] / sig, p[rows] / sig
        pp = float(np.sum(pg * pg))
        if pp <= 0:
            continue
        s = float(np.sum(mg * pg)) / pp
        if s <= 0:
            continue
        now = float(np.sum((mg - pg) ** 2))
        for F, meaning, fix in factors:
            if abs(math.log10(s / F)) >= tol:
                continue
            fixed = float(np.sum((mg / F - pg) ** 2))
            removed = 1.0 - fixed / now if now > 0 else 0.0
            if removed < min_removed:
                continue
            quantity = "measured"
            if med_load and med_load > 0:
                lg = float(np.median(load[rows])) / med_load
                if lg > 0 and abs(math.log10(lg * F)) < tol:
                    quantity = "load"
            if quantity == "load":
                meaning_q = meaning.replace("recorded in", "load recorded in")
                fix_q = f"multiply the load of these rows by {F:g}"
            else:
                meaning_q, fix_q = meaning, fix
            out.append(UnitSlip(cfg, rows, s, F, quantity, meaning_q, fix_q, removed))
            break
    return out


def angle_units(
    q: npt.ArrayLike, labels: Sequence[object] | None = None, limit: float = 2 * math.pi + 1e-6
) -> list[dict]:
    """Joint values beyond one turn (|q| > 2 pi) are very likely degrees:
    per configuration, the columns concerned."""
    q = np.atleast_2d(np.asarray(q, float))
    labels = [str(i) for i in range(q.shape[0])] if labels is None else labels
    out = []
    big = np.abs(q) > limit
    if not big.any():
        return out
    for cfg, rows in _groups(labels).items():
        cols = [j for j in range(q.shape[1]) if np.any(big[rows, j])]
        if cols:
            out.append(
                {
                    "config": cfg,
                    "rows": rows,
                    "columns": [f"q{j + 1}" for j in cols],
                    "meaning": "joint values beyond one turn: recorded in degrees instead of radians",
                    "fix": "multiply them by pi/180",
                }
            )
    return out


def copies(rows: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Exact copies among ``rows`` (n, m) (every number equal): (first, dup)
    where first[i] is the index of the first row equal to row i and dup the
    indices of the rows that repeat an earlier one."""
    rows = np.atleast_2d(np.asarray(rows, float))
    if rows.shape[0] == 0:
        return np.zeros(0, int), np.zeros(0, int)
    _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    head = first[np.ravel(inverse)]
    return head, np.flatnonzero(head != np.arange(rows.shape[0]))


def copies_message(rows: npt.ArrayLike, lines: Sequence[int], path: object) -> str | None:
    """The one warning for rows that repeat another exactly (or None):
    replicated measurements differ by their noise, a copy does not."""
    head, dup = copies(rows)
    if not dup.size:
        return None
    i = int(dup[0])
    more = f" ({dup.size} such rows)" if dup.size > 1 else ""
    return (
        f"{path}, line {lines[i]}: repeats line {lines[head[i]]} exactly{more}; replicated measurements differ "
        "by their noise, so this looks like a copied row"
    )


def drop_copies(data: object, rows: npt.ArrayLike) -> tuple[object, int]:
    """``data`` (anything with ``subset(indices)``) without the rows of
    ``rows`` that copy an earlier one, and how many were dropped. Exact
    copies are not replicates: they carry no noise and no new information,
    so a test or a noise estimate must not count them."""
    head, dup = copies(rows)
    if not dup.size:
        return data, 0
    return data.subset(np.flatnonzero(head == np.arange(head.size))), int(dup.size)


def cannot_judge(path: object, n_distinct: int, n_copies: int, why: str) -> InputError:
    """The error of a diagnosis that has no verdict to give from these data."""
    s = "" if n_distinct == 1 else "s"
    copied = (
        f" ({n_copies} more row{'' if n_copies == 1 else 's'} are exact copies: copies are not replicates and "
        "carry no noise)"
        if n_copies
        else ""
    )
    return InputError(f"{path}: cannot judge: {n_distinct} distinct row{s}{copied}; {why}")
