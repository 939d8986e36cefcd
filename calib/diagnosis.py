"""One diagnosis pipeline for both observation kinds (issue 15): the stages
and rules that deflections under known loads (``calib.diagnose``) and
absolute tracker positions (``calib.absolute_diagnose``) share; the entry
that runs either from its files, the one path of ``stiffkit diagnose``, is
``calib.diagnosis_files``.

The stages, in order, on either kind:

0. Rows: exact copies of an earlier row are dropped (:func:`distinct_rows`;
   copies are not replicates: they carry no noise and no information);
   a fit that fails on what is left, or that leaves fewer than
   MIN_RESIDUAL_DOF residual degrees of freedom, gives no verdict:
   "cannot judge: N distinct rows; a verdict needs at least M distinct
   rows" with M = :func:`min_rows` (:func:`judged_fit`,
   :func:`check_residual`).
1. Data checks, fit, adequacy: each kind's adapter (how to fit, how to
   predict, which rows, its data checks) in its module.
2. Candidates: the score test of every candidate's columns against the
   model's, in one core call (:func:`score_blocks`), and its statistic,
   degrees of freedom, log p-value, explained share and share of the
   residual above the noise (:func:`fill_scores`, one rule for the three
   sources of the noise level, :class:`Noise`); the held-out error of
   the leaders by cross-validation by configuration.
3. A checked proposal or why none, "nothing in the catalogue fits"; the
   report's common pieces in ``calib.diagnosis_report``.

The one rule of each decision, both kinds (docs/calibration.md 7.2):

- held-out check and ``--cv 0``: a candidate is proposed only when its
  held-out RMS (cross-validation by configuration, :func:`folds_of`) is at
  least CV_GAIN below the model's (:func:`lowers_held_out`); ``--cv 0``
  (or fewer than two configurations) switches the cross-validation off,
  and then nothing is proposed (NO_HELD_OUT); each kind may check its
  proposal further (tracker data: by a fit with it);
- multiplicity: a candidate's p-value is corrected for having looked at
  every candidate by the max-score test (:func:`corrected_p`, Monte Carlo
  in the core with the candidates' correlations; Bonferroni's bound when
  that is far below alpha); the best candidate's corrected test rejecting
  at alpha makes the verdict inadequate, and only a candidate whose own
  corrected test rejects is proposed (both report ``multiplicity_p``,
  ``multiplicity_method``, ``bonferroni_p``);
- ties: :func:`tie_rivals` (another target, significant on its own, within
  TIE_LOG10 in log10 p of the one to propose or significantly better held
  out); a tie blocks the proposal and names the command that plans the
  measurements telling them apart;
- nothing fits, with the noise known apart from the residual (declared
  sigma, pure error): :func:`catalogue_fails` (the best candidate explains
  less than NOTHING_FITS of the residual above the noise, the best three
  together less than TOGETHER_FITS, and the model with the best one is
  still inadequate); it blocks the proposal. Tracker data without a
  declared sigma (no such noise) judge by the residual's structure;
- data checks: gross errors (level OUTLIER_ALPHA, Bonferroni over the
  rows) and unit slips against a robust (Huber) fit, set aside unless more
  than ``robust.MAX_SET_ASIDE`` of the rows (then the misfit is the model's).

What the two kinds still decide each their own way (to be made one rule
each; today's tests pin both):

- adequacy without a declared sigma: deflections test lack of fit against
  the pure error of replicated rows (no replicates: cannot judge); tracker
  data have no test, the verdict rests on the held-out error and the
  residual's structure (calib/absolute_structure.py);
- proposal: deflections propose the untied leader; tracker data the
  candidate of lowest held-out error, checked by a fit with it (the
  simpler of two nested candidates first).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

import numpy as np
import numpy.typing as npt

from .._core import calib as core
from ..errors import InputError, StiffkitError
from .checks import cannot_judge, drop_copies
from .crossval import config_folds

if TYPE_CHECKING:
    from .diagnose_candidates import Candidate

__all__ = [
    "ALPHA",
    "CV_FOLDS",
    "MIN_RESIDUAL_DOF",
    "PROPOSAL_LINE",
    "NOTHING_FITS_LINE",
    "JSON_FIELDS",
    "min_rows",
    "distinct_rows",
    "judged_fit",
    "check_residual",
    "Noise",
    "score_blocks",
    "fill_scores",
    "bonferroni",
    "few_dof_warning",
    "CV_GAIN",
    "TIE_LOG10",
    "DUPLICATE_COS",
    "tie_rivals",
    "OUTLIER_ALPHA",
    "NOTHING_FITS",
    "TOGETHER_FITS",
    "catalogue_fails",
    "NSIM",
    "corrected_p",
    "NO_HELD_OUT",
    "folds_of",
    "lowers_held_out",
]

#: level of the adequacy tests
ALPHA = 0.01
#: folds of the cross-validation by configuration
CV_FOLDS = 5
#: a proposal must lower the model's held-out RMS by at least this fraction (both kinds): less is
#: within what the held-out estimate itself varies by, or the fit's own flexibility
CV_GAIN = 0.02
#: rivals within this many decades of the leader's p-value are undecidable together (both kinds)
TIE_LOG10 = 1.0
#: explained parts of two candidates this alike (cosine) are the same part of the residual
DUPLICATE_COS = 0.99
#: gross errors are judged against the residual of a model that may still lack effects (whose errors
#: are not Gaussian): a stricter level than the tests of the effects (Bonferroni over the rows), both kinds
OUTLIER_ALPHA = 1e-4
#: nothing fits: the best candidate explains less than this share of the residual above the noise ...
NOTHING_FITS = 0.5
#: ... and the best three (of different targets) together less than this
TOGETHER_FITS = 0.8
#: Monte Carlo draws of the max-score test (199 when the answer is settled on either side of alpha)
NSIM = 999
#: the seed of its draws (reproducible)
SEED = 20240601
#: why nothing is proposed without cross-validation (both kinds)
NO_HELD_OUT = (
    "no held-out check (cross-validation off: --cv 0, or fewer than two configurations): nothing is proposed without it"
)
#: a verdict needs at least this many residual degrees of freedom: with fewer, a fit absorbs most of
#: the noise, a chi-square or F test has next to no power and a held-out error rests on a few rows
MIN_RESIDUAL_DOF = 10
#: fewer residual degrees of freedom than this (or than half the observations): the warning
LOW_DOF = 30
#: the line before a proposal's ready [[effect]] table, both kinds
PROPOSAL_LINE = "proposal: append to the model and fit again:"
#: the headline when no catalogued effect explains what the model leaves, both kinds
NOTHING_FITS_LINE = "NOTHING IN THE CATALOGUE FITS"
#: a projected unit candidate column shorter than this adds nothing (the core's score test)
ZTOL = 1e-6
#: the JSON fields of the pipeline, both kinds (each kind adds its own)
JSON_FIELDS = (
    "observation_kind",
    "verdict",
    "test",
    "statistic",
    "dof",
    "log10_p_value",
    "alpha",
    "sigma_position_m",
    "sigma_source",
    "noise_floor_position_m",
    "rms_position_m",
    "residual_dof",
    "n_rows_distinct",
    "n_rows_copied",
    "min_residual_dof",
    "data_checks",
    "cv_rms_position_m",
    "cv_folds",
    "candidates",
    "n_tests",
    "multiplicity_p",
    "multiplicity_method",
    "bonferroni_p",
    "non_identifiable_candidates",
    "ties",
    "nothing_fits",
    "proposal",
    "no_proposal_reasons",
    "removal",
    "backward_steps",
    "prune",
    "warnings",
)

T = TypeVar("T")


def min_rows(n_params: int, coords: int) -> int:
    """The fewest distinct rows that leave MIN_RESIDUAL_DOF residual degrees
    of freedom to ``n_params`` identified parameters, ``coords``
    coordinates a row."""
    return max(1, math.ceil((int(n_params) + MIN_RESIDUAL_DOF) / max(int(coords), 1)))


def distinct_rows(data: T, rows: npt.ArrayLike) -> tuple[T, int]:
    """``data`` without the rows that copy an earlier one (``rows``: the
    values of each row), and how many were dropped."""
    return drop_copies(data, rows)  # type: ignore[return-value]


def _too_few(
    path: object, n: int, copies: int, n_params: int, coords: int, why: str, which: str = "identified"
) -> InputError:
    need = min_rows(n_params, coords)
    return cannot_judge(
        path,
        n,
        copies,
        f"{why}; a verdict needs at least {need} distinct rows ({n_params} {which} parameters + "
        f"{MIN_RESIDUAL_DOF} residual degrees of freedom, {coords} coordinates a row)",
    )


def judged_fit(fit: Callable[[], T], path: object, n: int, copies: int, n_free: int, coords: int) -> T:
    """``fit()`` on the distinct rows; when it fails on too few of them (fewer
    coordinates than the free parameters plus MIN_RESIDUAL_DOF), or when copies
    were dropped, the failure is a "cannot judge" that names the minimum."""
    try:
        return fit()
    except StiffkitError as exc:
        few = n * coords < n_free + MIN_RESIDUAL_DOF
        if not (few or copies):
            raise
        why = str(exc).removeprefix(f"{path}: ")
        if few:
            raise _too_few(path, n, copies, n_free, coords, f"the fit fails ({why})", "free") from None
        raise cannot_judge(path, n, copies, why) from None


def check_residual(path: object, n: int, copies: int, nobs: int, rank: int, coords: int) -> None:
    """No verdict from fewer than MIN_RESIDUAL_DOF residual degrees of freedom."""
    if nobs - rank < MIN_RESIDUAL_DOF:
        raise _too_few(
            path,
            n,
            copies,
            rank,
            coords,
            f"{nobs} coordinates for {rank} identified parameters leave {max(nobs - rank, 0)} residual degrees "
            "of freedom",
        )


@dataclass(frozen=True)
class Noise:
    """How the residual's sums of squares become test statistics: ``scale2``
    the noise variance of one weighted coordinate (1 when the weights
    whiten by a declared sigma), ``source`` "declared", "pure error" (the
    spread of replicated rows, ``d_pe`` degrees of freedom) or "residual"
    (the model's own residual, ``nres`` degrees of freedom)."""

    scale2: float
    source: str
    nres: int
    d_pe: int | None = None

    def excess(self, rss: float) -> float:
        """The residual above the noise, in chi-square units (0 when the noise
        is the residual itself)."""
        return 0.0 if self.source == "residual" else rss / self.scale2 - self.nres


def score_blocks(
    A: np.ndarray, r: np.ndarray, blocks: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The score test of each block of candidate columns against the model's
    columns ``A`` (core/sk_calib.f90): each block projected off ``A``, the
    residual ``r``'s sum of squares in what is left (raw, before the
    noise), its rank (the degrees of freedom; 0: spanned by the model) and
    the explained part of ``r`` (one column a block)."""
    n = A.shape[0]
    if not blocks:
        return np.zeros(0), np.zeros(0, int), np.zeros((n, 0))
    Z = np.hstack(list(blocks))
    cstart = np.cumsum([1] + [b.shape[1] for b in blocks]).astype(np.int32)
    st, dof, pr = core.score(A if A.shape[1] else np.zeros((n, 1)), r, Z, cstart, 1e-10, ZTOL)
    return np.asarray(st, float), np.asarray(dof, int), np.asarray(pr)


def fill_scores(cand: Candidate, st: float, d: int, noise: Noise, rss: float) -> None:
    """A candidate's scores from its raw score statistic ``st`` on ``d``
    degrees of freedom: statistic (in noise units), log p (chi-square
    against a declared sigma; F against the pure error; F against the
    residual left beside it when the noise is the residual's), share of the
    residual it explains, share of the residual above the noise (None when
    the noise is not known apart from the residual)."""
    cand.dof = int(d)
    cand.statistic = float(st / noise.scale2)
    if noise.source == "declared":
        cand.log_p = core.chi2_logsf(cand.statistic, d)
    elif noise.source == "pure error":
        cand.log_p = core.f_logsf(cand.statistic / d, d, noise.d_pe)
    else:
        rest = max(noise.nres - d, 1)
        cand.log_p = core.f_logsf((st / d) / (max(rss - st, 1e-300) / rest), d, rest)
    cand.explained_fraction = float(st / rss) if rss > 0 else 0.0
    excess = noise.excess(rss)
    cand.excess_fraction = max(float((cand.statistic - d) / excess), 0.0) if excess > 0 else None


def folds_of(labels: Sequence[object], k: int) -> list[np.ndarray]:
    """The folds of ``--cv K`` by configuration, both kinds
    (``crossval.config_folds``): none when K is 0 or the rows hold fewer
    than two configurations (no held-out check)."""
    folds = config_folds(labels, k) if k else []
    return folds if len(folds) >= 2 else []


def lowers_held_out(cv: float | None, cv_base: float | None) -> bool:
    """The proposal's held-out check, both kinds: the candidate's held-out
    RMS is at least CV_GAIN below the model's (False when either is unknown)."""
    return cv is not None and cv_base is not None and cv < cv_base * (1.0 - CV_GAIN)


def corrected_p(
    A: np.ndarray,
    blocks: Sequence[np.ndarray],
    log_p: float,
    alpha: float,
    d_pe: int = 0,
    nsim: int = NSIM,
    seed: int = SEED,
) -> tuple[float, int]:
    """A candidate's p-value (``log_p``) corrected for having looked at every
    candidate (the columns ``blocks``, against the model's ``A``), both
    kinds: the max-score test of the core (the probability, under the model
    with Gaussian noise, that any candidate's score test reaches ``log_p``,
    with the candidates' correlations; chi-square without ``d_pe``, else F
    against a variance on ``d_pe`` degrees of freedom), or Bonferroni's
    bound when that is far below alpha (the alarm is certain). Returns
    (p, draws; 0: Bonferroni's bound)."""
    p = math.exp(log_p)
    bonf = bonferroni(p, len(blocks))
    if bonf < 0.01 * alpha:
        return bonf, 0
    # the corrected p lies between the best p (one test) and Bonferroni's bound:
    # when both sides of alpha are settled, fewer draws give its value
    settled = p >= alpha or bonf < alpha
    ns = min(nsim, 199) if settled else nsim
    Z = np.hstack(list(blocks))
    cstart = np.cumsum([1] + [b.shape[1] for b in blocks]).astype(np.int32)
    A = A if A.shape[1] else np.zeros((A.shape[0], 1))
    return float(core.max_score(A, Z, cstart, 1e-10, ZTOL, log_p, int(d_pe), ns, seed)), ns


def _nested(A: np.ndarray, Zs: np.ndarray, Zb: np.ndarray) -> bool:
    """Do the columns Zb span Zs off the model A (the smaller candidate is
    part of the bigger one, e.g. a joint's column in the next link's
    spring)?"""
    AZ = np.hstack([A, Zb])
    if AZ.shape[1] >= AZ.shape[0]:
        return True  # as many columns as observations: they span what the data can tell
    _, dof, _ = core.score(AZ, np.zeros(AZ.shape[0]), Zs, np.array([1, Zs.shape[1] + 1], np.int32), 1e-10, ZTOL)
    return int(dof[0]) == 0


def _cos(a: np.ndarray, b: np.ndarray) -> float:
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    return float(a @ b) / (na * nb) if na > 0 and nb > 0 else 0.0


def _cv_better(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Paired comparison over configurations: is b's held-out error
    significantly below a's (t < -2)?"""
    if a is None or b is None or a.size < 3:
        return False
    d = b - a
    d = d[np.isfinite(d)]
    if d.size < 3:
        return False
    se = float(np.std(d, ddof=1)) / math.sqrt(d.size)
    return bool(se > 0 and d.mean() / se < -2.0)


def tie_rivals(lead: Candidate, ranked: Sequence[Candidate], A: np.ndarray, alpha: float) -> list[Candidate]:
    """The one tie rule, both kinds: the candidates the data cannot tell from
    ``lead`` (the one to propose), one a family (kind and target): of
    another family, significant at alpha on their own, with a log10 p
    within TIE_LOG10 of the leader's (or better) or a held-out error
    significantly lower (paired over configurations, ``_cv``). Nested
    candidates (the columns ``_cols`` of one in the span of the model's and
    the other's, e.g. joint offsets inside frame errors) are not rivals:
    the one proposed is the step, and the rest remains a candidate of the
    next step."""
    sig = math.log(alpha)
    out: list[Candidate] = []
    for c in ranked:
        if c is lead or c.family == lead.family or c.log_p >= sig:
            continue
        if _nested(A, lead._cols, c._cols) or _nested(A, c._cols, lead._cols):
            continue  # nested: not rivals (the one proposed is the step, the rest a candidate of the next)
        close_p = (c.log_p - lead.log_p) / math.log(10) <= TIE_LOG10
        if (close_p or _cv_better(lead._cv, c._cv)) and all(t.family != c.family for t in out):
            out.append(c)
    return out


def catalogue_fails(
    ranked: Sequence[Candidate], A: np.ndarray, r: np.ndarray, noise: Noise, alpha: float
) -> tuple[bool, float | None]:
    """The one nothing-fits rule, both kinds, on a model found inadequate
    with the noise known apart from the residual (declared sigma or pure
    error; ``ranked`` best first, with their columns ``_cols``): the best
    candidate explains less than NOTHING_FITS of the residual above the
    noise, the best three of different targets (significant on their own)
    together less than TOGETHER_FITS, and the model with the best one is
    still inadequate (chi-square of what it leaves). Returns (nothing fits,
    the share the best three explain together, or None when not needed)."""
    if not ranked:
        return True, None
    rss = float(r @ r)
    excess = noise.excess(rss)
    lead = ranked[0]
    if not excess > 0 or lead.excess_fraction is None or lead.excess_fraction >= NOTHING_FITS:
        return False, None
    sig = math.log(alpha)
    fams, blocks = [], []
    for c in ranked:
        if c.family not in fams and c.log_p < sig:
            fams.append(c.family)
            blocks.append(c._cols)
        if len(blocks) == 3:
            break
    together = lead.excess_fraction
    if len(blocks) > 1:
        Zt = np.hstack(blocks)
        if A.shape[1] + Zt.shape[1] >= A.shape[0]:
            return False, None  # as many columns as observations: no test of what they leave
        st, dt, _ = core.score(A, r, Zt, np.array([1, Zt.shape[1] + 1], np.int32), 1e-10, ZTOL)
        together = float((st[0] / noise.scale2 - dt[0]) / excess)
    rest = rss / noise.scale2 - lead.statistic
    rest_dof = noise.nres - lead.dof
    left = core.chi2_logsf(rest, rest_dof) < sig if rest_dof > 0 else False
    return bool(together < TOGETHER_FITS and left), together


def bonferroni(p_best: float, n_tests: int) -> float:
    """Bonferroni's bound on the p-value of the best of ``n_tests`` candidates."""
    return min(1.0, n_tests * p_best) if n_tests else 1.0


def few_dof_warning(dof: int, nobs: int, n_params: int) -> str | None:
    """The warning of a judged fit with few residual degrees of freedom
    (fewer than LOW_DOF, or than half the observations), both kinds."""
    if not (dof < LOW_DOF or dof < 0.5 * nobs):
        return None
    return (
        f"few residual degrees of freedom: {dof} of {nobs} observations ({n_params} parameters); "
        f"the tests have little power and a fit absorbs part of the noise (expected RMS "
        f"{math.sqrt(max(dof, 0) / nobs):.2f} x the noise floor); judge by the held-out error"
    )
