"""Candidate postures for ``stiffkit plan`` (issue 19): postures sampled
uniformly within the joint limits, or a user's own list, kept when the
robot clears itself and the floor and, for tracker data, when the tracker
sees every marker.

- Limits: the URDF's, tightened by the model file's ``[plan] limits``;
  a continuous joint (or one without limits) within [-pi, pi] unless
  ``[plan]`` limits it. Only the actuated joints are sampled (the
  columns); a mimic follower takes its law, ``multiplier * q_leader +
  offset``, and the posture is rejected ("joint limit") when that is
  outside the follower's own limits.
- Self-collision: capsules around the kinematic skeleton or the URDF's
  primitive shapes (robot/plan_skeleton.py: which pairs are tested); a
  posture is rejected when two tested capsules are closer than the margin
  (their segments' distance below r_i + r_j + margin).
- Floor (``[plan] floor_z``): rejected when a capsule's lowest point,
  min(z_a, z_b) - r, is below floor_z + margin (the base body excepted).
- View (``[plan] tracker``, absolute data): "out of view" when the angle
  between the tracker's direction and the line from the tracker to a
  marker exceeds cone_deg; "occluded" when that line passes within a
  capsule's radius of its segment (capsules of the marker's own body
  excepted).

A rejected posture is counted once, under the first of REASONS it fails.
Frames come from the model's forward kinematics (the cores), batched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_toml
from .capsules import segment_distance
from .model import load_model
from .plan_settings import PlanSettings, cone_cos, parse_plan, plan_table
from .plan_skeleton import Skeleton, skeleton
from .tree_model import load_tree_model, model_kind

__all__ = ["Candidates", "PlanSettings", "plan_settings", "sample_postures", "feasible", "REASONS", "joint_bounds"]

REASONS = ("joint limit", "self-collision", "floor", "out of view", "occluded")
#: postures checked per batch, at most
BATCH = 2000
#: postures drawn per round of sampling: twice those still missing, at least this many
DRAW_MIN = 64
#: doubles of one temporary array of a batch's checks (postures x (capsule pairs + markers x capsules) x 3)
BATCH_DOUBLES = 3_000_000
#: give up when this many sampled postures gave no feasible one
GIVE_UP = 10_000
#: at most this many tries per requested candidate
TRIES_PER_CANDIDATE = 20
#: a posture this far beyond a limit (rad or m) is beyond it
LIMIT_TOL = 1e-9
_HINTS = {
    "joint limit": "loosen the [plan] limits of the mimic leaders or followers",
    "self-collision": "loosen [plan] margin or radius",
    "floor": "lower [plan] floor_z (or loosen [plan] margin)",
    "out of view": "widen [plan] tracker cone_deg or point the tracker at the workspace",
    "occluded": "move the [plan] tracker or reduce the radius of the occluding links",
}


@dataclass
class Candidates:
    """Feasible postures (module docstring).

    q (m, nq): the postures, columns ``joint_names`` (the actuated joints;
    mimic followers follow their law); rejected: reason -> count; tried:
    postures checked; rows: for :func:`feasible`, the 0-based rows of the
    user's list that were kept, and ``failed``: 0-based row -> why it
    failed; loads (nl, 6) the [plan] loads (deflection data) or None."""

    q: np.ndarray
    joint_names: list[str]
    rejected: dict[str, int]
    tried: int
    rows: np.ndarray | None = None
    failed: dict[int, str] = field(default_factory=dict)
    loads: np.ndarray | None = None
    model: object = field(default=None, repr=False)
    settings: PlanSettings | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def check(self) -> None:
        """Re-verify every posture (limits, collisions, floor, view); raises
        InputError naming the first row that fails."""
        if not len(self):
            return
        geo = _Checks(self.model, self.settings)
        reason, detail = geo.run(self.q, details=True)
        bad = np.flatnonzero(reason >= 0)
        if bad.size:
            k = int(bad[0])
            raise InputError(f"candidate {k + 1}: {REASONS[reason[k]]} ({detail[k]})")

    def take(self, index: object) -> Candidates:
        """The candidates at ``index`` (0-based rows of q, e.g. a selected design), same model and settings."""
        idx = np.asarray(index, int).reshape(-1)
        if idx.size and (idx.min() < 0 or idx.max() >= len(self)):
            raise InputError(f"candidate index out of range 0..{len(self) - 1}: {idx.tolist()}")
        rows = None if self.rows is None else self.rows[idx]
        return Candidates(
            self.q[idx],
            list(self.joint_names),
            dict(self.rejected),
            self.tried,
            rows,
            {},
            self.loads,
            self.model,
            self.settings,
        )

    def failure_lines(self, most: int = 10, first_row: int = 1) -> list[str]:
        """ "row N: reason (detail)" for the failed rows of :func:`feasible`
        (row numbers from ``first_row``: 1 for a list, 2 for a CSV with a
        header), at most ``most`` lines and one saying how many more."""
        keys = sorted(self.failed)
        out = [f"row {k + first_row}: {self.failed[k]}" for k in keys[:most]]
        if len(keys) > most:
            out.append(f"... and {len(keys) - most} more")
        return out

    def summary(self) -> str:
        """One line: kept, tried and the rejections by reason."""
        rej = ", ".join(f"{n:,} {r}" for r, n in self.rejected.items() if n)
        return f"{len(self):,} feasible of {self.tried:,} tried" + (f" ({rej} rejected)" if rej else "")


def plan_settings(model_path: str | Path | object, model: object = None) -> PlanSettings:
    """The [plan] settings of a model file (defaults without the table).
    ``model_path``: the file, or a loaded model (TreeModel or Model, whose
    ``plan`` table and ``path`` are used); ``model``: the loaded model of
    that file when the caller has it (else it is loaded, by its kind)."""
    if not isinstance(model_path, (str, Path)):
        model = model_path
        return parse_plan(getattr(model, "plan", {}) or {}, getattr(model, "path", None) or "model", model)
    path = Path(model_path)
    if model is None:
        model = load_tree_model(path) if model_kind(path) == "absolute" else load_model(path)
        table = model.plan
    else:
        table = plan_table(read_toml(path, "model"), path)
    return parse_plan(table, path, model)


def joint_bounds(model: object, settings: PlanSettings) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(actuated joint names, lower (nq,), upper (nq,)): the URDF's limits
    tightened by [plan], [-pi, pi] for a joint without limits."""
    if hasattr(model, "tree"):
        names = model.tree.actuated
        urdf = [model.tree.joint(n).limit for n in names]
    else:
        names = model.chain.actuated
        urdf = list(model.chain.limits)
    lo, hi = np.empty(len(names)), np.empty(len(names))
    for k, (n, lim) in enumerate(zip(names, urdf)):
        if n in settings.limits:
            lim = settings.limits[n]
        elif lim is None:
            if hasattr(model, "tree") and model.tree.joint(n).type == "prismatic":
                raise InputError(f"{settings.where}: the prismatic joint {n!r} has no URDF limits; give limits.{n}")
            lim = (-math.pi, math.pi)
        lo[k], hi[k] = lim
    return list(names), lo, hi


def _followers(model: object, settings: PlanSettings) -> list[tuple[str, int, float, float, float, float]]:
    """(name, leader column, multiplier, offset, lower, upper) of every mimic follower with limits."""
    if not hasattr(model, "tree"):
        return []
    tree = model.tree
    cols = {n: k for k, n in enumerate(tree.actuated)}
    out = []
    for j in tree.joints:
        if not j.moving or j.mimic is None:
            continue
        lim = settings.limits.get(j.name, j.limit)
        if lim is None:
            continue
        lead, mult, off = tree.leader(j.name)
        out.append((j.name, cols[lead], mult, off, lim[0], lim[1]))
    return out


class _Checks:
    """Every test of one model and settings, on batches of postures."""

    def __init__(self, model: object, settings: PlanSettings | None) -> None:
        self.model = model
        self.settings = settings if settings is not None else plan_settings(model)
        self.names, self.lo, self.hi = joint_bounds(model, self.settings)
        self.followers = _followers(model, self.settings)
        q_ref = np.where(np.isfinite(self.lo + self.hi), 0.5 * (self.lo + self.hi), 0.0)
        self.sk: Skeleton = skeleton(model, self.settings, q_ref)
        tr = self.settings.tracker
        if tr is not None and not self.sk.marker_link.size:
            raise InputError(f"{self.settings.where} tracker: the model has no marker to view")

    def run(self, Q: np.ndarray, details: bool = False) -> tuple[np.ndarray, list[str]]:
        """(reason index per row, -1 when feasible; details per row when asked)."""
        n = Q.shape[0]
        reason = np.full(n, -1)
        detail = [""] * n if details else []
        sk = self.sk
        per = 3 * (sk.pairs.shape[0] + sk.marker_link.size * sk.radius.size) + 1
        rows = int(min(BATCH, max(16, BATCH_DOUBLES // per)))
        for start in range(0, n, rows):
            sl = slice(start, min(n, start + rows))
            r, d = self._batch(Q[sl], details)
            reason[sl] = r
            if details:
                detail[sl] = d
        return reason, detail

    def _batch(self, Q: np.ndarray, details: bool) -> tuple[np.ndarray, list[str]]:
        s, sk = self.settings, self.sk
        n = Q.shape[0]
        why = np.full(n, -1)
        text = [""] * n

        def mark(k: int, bad: np.ndarray, say=None) -> None:  # noqa: ANN001
            new = bad & (why < 0)
            why[new] = k
            if details and say is not None:
                for i in np.flatnonzero(new):
                    text[i] = say(i)

        tol = LIMIT_TOL
        out = (Q < self.lo - tol) | (Q > self.hi + tol)
        mark(0, out.any(axis=1), lambda i: self._limit_text(Q[i], np.flatnonzero(out[i])[0]))
        for name, col, mult, off, lo, hi in self.followers:
            v = mult * Q[:, col] + off
            mark(
                0,
                (v < lo - tol) | (v > hi + tol),
                lambda i, name=name, v=v, lo=lo, hi=hi: f"mimic joint {name} = {v[i]:.6g} outside [{lo:g}, {hi:g}]",
            )
        A, B, M = sk.world(Q)
        if sk.pairs.size:
            i, j = sk.pairs.T
            gap = segment_distance(A[:, i], B[:, i], A[:, j], B[:, j]) - sk.radius[i] - sk.radius[j]
            hit = gap < s.margin
            worst = np.argmin(gap, axis=1)
            mark(
                1,
                hit.any(axis=1),
                lambda r: (
                    f"{sk.labels[i[worst[r]]]} and {sk.labels[j[worst[r]]]}: clearance {gap[r, worst[r]]:.4g} m "
                    f"< margin {s.margin:g} m"
                ),
            )
        if s.floor_z is not None and sk.floor.any():
            low = np.minimum(A[:, sk.floor, 2], B[:, sk.floor, 2]) - sk.radius[sk.floor]
            fl = np.flatnonzero(sk.floor)
            mark(
                2,
                (low < s.floor_z + s.margin).any(axis=1),
                lambda r: (
                    f"{sk.labels[fl[np.argmin(low[r])]]} reaches z = {low[r].min():.4g} m, below floor_z + margin = "
                    f"{s.floor_z + s.margin:g} m"
                ),
            )
        if s.tracker is not None:
            self._view(M, A, B, mark)
        return why, text

    def _view(self, M: np.ndarray, A: np.ndarray, B: np.ndarray, mark) -> None:  # noqa: ANN001
        tr, sk = self.settings.tracker, self.sk
        T, u = tr["position"], tr["direction"]
        v = M - T
        dist = np.linalg.norm(v, axis=2)
        cos = np.einsum("nki,i->nk", v, u) / np.where(dist > 0, dist, 1.0)
        out = (cos < cone_cos(self.settings)) | (dist == 0)
        frames = self.model.frames
        mark(
            3,
            out.any(axis=1),
            lambda r: (
                f"marker on {frames[int(np.argmax(out[r]))]!r} at "
                f"{math.degrees(math.acos(np.clip(cos[r, int(np.argmax(out[r]))], -1, 1))):.1f} deg from the tracker's "
                f"direction (cone {tr['cone_deg']:g} deg)"
            ),
        )
        if not sk.radius.size:
            return
        Tb = np.broadcast_to(T, M.shape)
        d = segment_distance(Tb[:, :, None], M[:, :, None], A[:, None], B[:, None])  # (n, nm, nc)
        blocked = (d < sk.radius) & ~sk.own[None]
        hit = blocked.any(axis=2)

        def say(r: int) -> str:
            k = int(np.argmax(hit[r]))
            c = int(np.argmax(blocked[r, k]))
            return f"marker on {frames[k]!r} hidden by {sk.labels[c]} (line of sight {d[r, k, c]:.4g} m from its axis)"

        mark(4, hit.any(axis=1), say)

    def _limit_text(self, q: np.ndarray, k: int) -> str:
        return f"joint {self.names[k]} = {q[k]:.6g} outside [{self.lo[k]:g}, {self.hi[k]:g}]"


def _counts(reason: np.ndarray) -> dict[str, int]:
    return {r: int(np.count_nonzero(reason == k)) for k, r in enumerate(REASONS)}


def _loads(settings: PlanSettings) -> np.ndarray | None:
    return None if settings.loads is None else np.array(settings.loads, float).reshape(-1, 6)


def _nothing(tried: int, rejected: dict[str, int], settings: PlanSettings) -> InputError:
    parts = [f"{n:,} {r}" for r, n in sorted(rejected.items(), key=lambda x: -x[1]) if n]
    hints = [_HINTS[r] for r, n in sorted(rejected.items(), key=lambda x: -x[1]) if n]
    if rejected.get("self-collision") and rejected.get("floor"):  # one piece of advice on the margin
        hints = [h.replace(" (or loosen [plan] margin)", "") for h in hints]
    return InputError(
        f"{settings.where}: no feasible candidate: {tried:,} tried, {', '.join(parts)}; {'; '.join(hints[:2])}"
    )


def sample_postures(model: object, n: int, seed: int = 0, settings: PlanSettings | None = None) -> Candidates:
    """``n`` feasible postures drawn uniformly within the limits (module
    docstring) with ``numpy.random.default_rng(seed)``, in the order drawn.
    Stops after TRIES_PER_CANDIDATE x n tries (at least GIVE_UP): fewer
    than n are then returned (``summary()`` says how many were tried);
    InputError when none is feasible after GIVE_UP tries, naming the
    rejections and what to loosen."""
    n = V.count(n, "candidates", 1, 10**7)
    seed = V.count(seed, "seed", 0)
    checks = _Checks(model, settings)
    s = checks.settings
    rng = np.random.default_rng(seed)
    most = max(TRIES_PER_CANDIDATE * n, GIVE_UP)
    kept, tried = [], 0
    reasons = []
    found = 0
    while found < n and tried < most:
        m = min(most - tried, max(DRAW_MIN, 2 * (n - found)))
        Q = rng.uniform(checks.lo, checks.hi, (m, checks.lo.size))
        r, _ = checks.run(Q)
        ok = np.flatnonzero(r < 0)
        if found + ok.size >= n:  # the first n feasible: count the tries up to the n-th
            last = int(ok[n - found - 1]) + 1
            ok, r, Q = ok[: n - found], r[:last], Q[:last]
        kept.append(Q[ok])
        reasons.append(r)
        tried += r.size
        found += ok.size
        if found == 0 and tried >= GIVE_UP:
            break
    reason = np.concatenate(reasons) if reasons else np.zeros(0, int)
    rejected = _counts(reason)
    if found == 0:
        raise _nothing(tried, rejected, s)
    return Candidates(
        q=np.vstack(kept),
        joint_names=checks.names,
        rejected=rejected,
        tried=tried,
        loads=_loads(s),
        model=model,
        settings=s,
    )


def feasible(model: object, Q: object, settings: PlanSettings | None = None, where: str = "postures") -> Candidates:
    """The same checks on a user's postures Q (m, nq), columns the actuated
    joints in the model's order: ``rows`` the 0-based rows kept,
    ``failed`` {0-based row: "reason (detail)"} for the others (messages
    give 1-based row numbers). ``where`` names the list in messages."""
    checks = _Checks(model, settings)
    Q = np.atleast_2d(V.array(Q, where, (None, checks.lo.size), "angle"))
    reason, detail = checks.run(Q, details=True)
    ok = np.flatnonzero(reason < 0)
    failed = {int(i): f"{REASONS[reason[i]]} ({detail[i]})" for i in np.flatnonzero(reason >= 0)}
    return Candidates(
        q=Q[ok],
        joint_names=checks.names,
        rejected=_counts(reason),
        tried=Q.shape[0],
        rows=ok,
        failed=failed,
        loads=_loads(checks.settings),
        model=model,
        settings=checks.settings,
    )
