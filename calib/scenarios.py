"""Messy calibration data with a known cause: the scenarios the diagnosis
is tested and benchmarked on.

Each scenario is the KR-270-like robot of ``synth`` (joint compliances,
aluminium-tube links 2-4, a gravity compensator on A2), measured as in
``examples/kr270`` (configurations x random 2.5 kN loads x markers, noise
sigma per coordinate), with one thing wrong that the user's model (the
truth's own effects, no values) does not know about:

- ``control``: nothing; the model is right.
- ``outliers``: a fraction of the rows carry a gross marker error (5 mm in
  a random direction).
- ``unit_slip``: one configuration recorded in mm instead of m.
- ``hardening``: joint A2 stiffens with the load (dq = c tau + c3 tau^3,
  c3 < 0); ``hardening_smooth`` with a law that is not a cubic,
  dq = c tau / sqrt(1 + (tau / tau_h)^2).
- ``deadzone``: joint A3 has backlash +-b (a sharp dead zone).
- ``profile``: a posture-dependent compliance of A3 (joint_profile).
- ``drift``: the measuring device drifts with time (a smooth offset along
  the row order).
- ``weak``: a weak effect (a beam spring of link 5), scaled so that the
  part of it the model cannot absorb has a given size against the noise.
- ``few_rows``: as ``profile`` but with a link 2 spring hidden and only 18
  rows (6 configurations x 3 loads x 1 marker).

The defaults size the load-nonlinear joints so that the user's model
leaves a positional RMS of about 0.09 mm against the 0.035 mm noise floor.

``make_scenario(name, seed)`` returns a :class:`Scenario`: the chain, the
user's model (effects without values, sigma declared), the measurements,
the truth and what was done (``info``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..robot.model import Model, model_from_tables
from .measure import Measurements
from .problem import Problem
from .synth import KR270_COMPENSATOR, KR270_JOINTS, KR270_RANGES, kr270_links, kr270_truth, synthesize

if TYPE_CHECKING:
    from ..robot.urdf import Chain

__all__ = ["Scenario", "make_scenario", "SCENARIOS", "base_effects", "hidden_size"]

MARKERS = ((0.0, 0.0, 0.25), (0.12, 0.0, 0.2), (0.0, 0.12, 0.2))
GEOM = {k: KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")}

SCENARIOS = (
    "control",
    "outliers",
    "unit_slip",
    "hardening",
    "hardening_smooth",
    "deadzone",
    "profile",
    "drift",
    "weak",
    "few_rows",
)


@dataclass
class Scenario:
    name: str
    chain: object
    model: Model  # what the user fits (no values)
    meas: Measurements
    truth: Model
    sigma: float
    info: dict = field(default_factory=dict)

    @property
    def floor(self) -> float:
        """Noise floor of the positional RMS, sqrt(3) sigma (m)."""
        return math.sqrt(3) * self.sigma


def base_effects(links: Iterable[int] = (2, 3, 4), compensator: bool = True) -> list[dict]:
    """The user's model of the KR-270-like truth: joints, beam links, the
    compensator with its datasheet geometry."""
    eff = [{"kind": "joint", "target": "all"}]
    eff += [{"kind": "link", "target": f"link_{i}", "template": "beam"} for i in links]
    if compensator:
        eff.append({"kind": "gravity_compensator", "target": "joint_a2", **GEOM})
    return eff


def _truth(links: Iterable[int] = (2, 3, 4)) -> list[dict]:
    lk = kr270_links()
    out = [e for e in kr270_truth(links=False)]
    out += [{"kind": "link", "target": f"link_{i}", "value": lk[f"link_{i}"].tolist()} for i in links]
    return out


def hidden_size(chain: Chain, meas: Measurements, model: Model, extra: list[dict], sigma: float) -> float:
    """Norm, in units of sigma, of the part of the deflection of the effects
    ``extra`` (tables with values) that the model's columns cannot absorb
    (the non-centrality of its score test is this squared)."""
    pb = Problem(model, meas)
    _, J = pb.evaluate(np.zeros(pb.npar))
    A = pb.weighted(J) / (pb.wrow[0])
    em = model_from_tables(chain, extra)
    pred, _ = Problem(em, meas).evaluate(np.zeros(0), jac=False)
    y = pb.weighted(pred) / pb.wrow[0]
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(np.linalg.norm(y - A @ coef) / sigma)


def make_scenario(
    name: str,
    seed: int = 0,
    sigma: float = 2e-5,
    n_configs: int = 30,
    loads_per_config: int = 3,
    markers: Sequence[Sequence[float]] = MARKERS,
    strength: float | None = None,
    noise: bool = True,
    fresh: bool = False,
) -> Scenario:
    """Data of one scenario (see the module text); ``strength`` sets the
    size of the defect where it has one (outliers: fraction of rows;
    hardening: the relative loss of compliance at the RMS torque; deadzone:
    b in rad; drift: amplitude in m; weak: the unabsorbed norm in sigma).
    ``noise`` False leaves the Gaussian noise out (sigma is still declared),
    so that replicas can add their own. ``fresh`` True gives new data of the
    same robot and physics for checking predictions: no data errors
    (outliers, unit slips, drift) and the full design for ``few_rows``."""
    if name not in SCENARIOS:
        raise InputError(f"unknown scenario {name!r}; choose one of {', '.join(SCENARIOS)}")
    rng = np.random.default_rng(10_000 + seed)
    links = (2, 3, 4)
    truth = _truth(links)
    effects = base_effects(links)
    info: dict = {}
    if name == "few_rows" and not fresh:
        n_configs, loads_per_config, markers = 6, 3, markers[:1]
    if name == "few_rows":
        truth = [e for e in truth if not (e["kind"] == "link")]
        truth.append({"kind": "link", "target": "link_3", "value": kr270_links()["link_3"].tolist()})
        effects = [{"kind": "joint", "target": "all"}, {"kind": "gravity_compensator", "target": "joint_a2", **GEOM}]
        info["hidden"] = {"kind": "link", "target": "link_3"}
    if name == "profile":
        truth.append({"kind": "joint_profile", "target": "joint_a3", "value": [0.0, 6e-8, -4e-8, 3e-8, 2e-8]})
        info["hidden"] = {"kind": "joint_profile", "target": "joint_a3"}
    kw = dict(
        n_configs=n_configs,
        loads_per_config=loads_per_config,
        markers=markers,
        ranges=KR270_RANGES,
        seed=seed,
        sigma=0.0,
    )
    chain, tm, meas = synthesize(KR270_JOINTS, truth, **kw)
    model = model_from_tables(chain, effects, sigma_position=sigma)
    tau = chain.joint_torques(meas.q, meas.w)
    extra: list[dict] = []
    if name in ("hardening", "hardening_smooth"):
        j = chain.joint_index("joint_a2")
        trms = float(np.sqrt(np.mean(tau[:, j] ** 2)))
        loss = (0.07 if name == "hardening" else 0.09) if strength is None else strength
        c = 2.0e-7
        if name == "hardening":
            extra = [{"kind": "joint_cubic", "target": "joint_a2", "value": -loss * c / trms**2}]
        else:
            # c tau / sqrt(1 + (tau/th)^2) loses `loss` of its compliance at the RMS torque
            th = trms / math.sqrt((1.0 / (1.0 - loss)) ** 2 - 1.0)
            info["tau_h"] = th
        info["hidden"] = {"kind": "joint_cubic", "target": "joint_a2"}
    elif name == "deadzone":
        b = 1.4e-4 if strength is None else strength
        # a sharp dead zone: smoothed far below the candidate's tau0
        extra = [{"kind": "joint_deadzone", "target": "joint_a3", "value": b, "tau0": 1.0}]
        info["hidden"] = {"kind": "joint_deadzone", "target": "joint_a3"}
    elif name == "weak":
        lk = np.diag([1e-9, 4e-9, 4e-9, 1e-8, 1e-8, 1e-8])
        probe = [{"kind": "link", "target": "link_5", "value": lk.tolist()}]
        size = hidden_size(chain, meas, model, probe, sigma)
        target = 4.0 if strength is None else strength
        extra = [{"kind": "link", "target": "link_5", "value": (lk * target / size).tolist()}]
        info["hidden"] = {"kind": "link", "target": "link_5"}
        info["unabsorbed_sigma"] = target
    if extra:
        em = model_from_tables(chain, extra)
        pred, _ = Problem(em, meas).evaluate(np.zeros(0), jac=False)
        meas.d = meas.d + pred[0:3].T
        tm = model_from_tables(chain, truth + extra, where="truth")
    if name == "hardening_smooth":
        j = chain.joint_index("joint_a2")
        pb = Problem(model_from_tables(chain, [{"kind": "joint", "target": "joint_a2", "value": 1.0}]), meas)
        g = pb.evaluate(np.zeros(0), jac=False)[0]  # J tau per unit compliance
        c, th = 2.0e-7, info["tau_h"]
        meas.d = meas.d + (g[0:3] * (c / np.sqrt(1.0 + (tau[:, j] / th) ** 2) - c)).T
    if noise:
        meas.d = meas.d + sigma * rng.normal(size=meas.d.shape)
    if fresh:
        pass
    elif name == "outliers":
        frac = 0.03 if strength is None else strength
        k = max(1, int(round(frac * meas.n)))
        rows = np.sort(rng.choice(meas.n, k, replace=False))
        v = rng.normal(size=(k, 3))
        meas.d[rows] += 5e-3 * v / np.linalg.norm(v, axis=1, keepdims=True)
        info["rows"] = [int(i) for i in rows]
    elif name == "unit_slip":
        labels = sorted(set(meas.config), key=meas.config.index)
        cfg = labels[int(rng.integers(len(labels)))]
        rows = [i for i, c in enumerate(meas.config) if c == cfg]
        meas.d[rows] *= 1e3
        info["config"] = cfg
        info["rows"] = rows
    elif name == "drift":
        amp = 0.1e-3 if strength is None else strength
        t = np.linspace(0.0, 1.0, meas.n)
        meas.d = meas.d + amp * np.column_stack([t, 0.5 * t**2, -0.7 * t])
        info["amplitude"] = amp
    info["floor"] = math.sqrt(3) * sigma
    return Scenario(name=name, chain=chain, model=model, meas=meas, truth=tm, sigma=sigma, info=info)
