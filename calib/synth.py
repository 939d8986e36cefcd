"""Synthetic calibration data with a known truth.

``synthesize`` takes a robot (URDF joint list), a truth (effect tables with
values: joint and link compliances, joint profiles, gravity compensator,
point offset, ...), postures, loads, markers and noise, and returns the
measurement rows the truth predicts plus Gaussian noise. ``write_synth``
writes robot.urdf, model.toml (the effects to identify, no values),
truth.toml (the truth with values) and measurements.csv.

The built-in example is a KR-270-like 6R robot: dimensions of the public
KUKA KR 270 R2700 datasheet (approximate: A1 height 675 mm, A1-A2 offset
350 mm, upper arm 1150 mm, A3 offset 41 mm, forearm 1200 mm, flange
215 mm), aluminium-tube link compliances, joint compliances of the magnitude
klimchik reports, and a gravity compensator on A2.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..field import cantilever_compliance, section_properties
from ..io import validate as V
from ..io.files import atomic_write_text, check_folder, check_output
from ..io.tables import read_text
from ..robot.model import Model, model_from_tables
from ..robot.model_file import model_toml
from ..robot.urdf import Chain, load_chain, urdf_text
from .measure import Measurements, write_measurements
from .problem import Problem

KR270_JOINTS = [
    dict(name="joint_a1", type="revolute", parent="base_link", child="link_1", xyz=(0, 0, 0.675), axis=(0, 0, 1)),
    dict(name="joint_a2", type="revolute", parent="link_1", child="link_2", xyz=(0.350, 0, 0), axis=(0, 1, 0)),
    dict(name="joint_a3", type="revolute", parent="link_2", child="link_3", xyz=(1.150, 0, 0), axis=(0, 1, 0)),
    dict(name="joint_a4", type="revolute", parent="link_3", child="link_4", xyz=(0.600, 0, 0.041), axis=(1, 0, 0)),
    dict(name="joint_a5", type="revolute", parent="link_4", child="link_5", xyz=(0.600, 0, 0), axis=(0, 1, 0)),
    dict(name="joint_a6", type="revolute", parent="link_5", child="link_6", xyz=(0.100, 0, 0), axis=(1, 0, 0)),
    dict(name="joint_tool", type="fixed", parent="link_6", child="tool0", xyz=(0.115, 0, 0), rpy=(0, math.pi / 2, 0)),
]

#: posture ranges (rad) used to draw calibration configurations
KR270_RANGES = [(-2.5, 2.5), (-1.4, 0.2), (-1.0, 1.2), (-2.5, 2.5), (0.4, 1.9), (-2.5, 2.5)]

KR270_JOINT_C = [3.0e-7, 2.0e-7, 3.0e-7, 1.5e-6, 1.6e-6, 2.5e-6]  # rad/(N m)

KR270_COMPENSATOR = dict(a=0.45, b=0.12, beta=0.3, s0=0.25, k_s=5.0e7)

#: the most measurement rows one synthesis writes (a CSV of ~100 MB)
MAX_ROWS = 10**6
#: the files write_synth writes into its folder
OUTPUT_FILES = ("robot.urdf", "model.toml", "truth.toml", "measurements.csv")


def beam_compliance(length: float, E: float, nu: float, outer: float, inner: float) -> np.ndarray:
    """Tip compliance of a tube cantilever along x (eq. 22, Euler-Bernoulli)."""
    return cantilever_compliance(length, E, nu, section_properties("tube", [outer, inner], nu))


def kr270_links() -> dict[str, np.ndarray]:
    """Link spring compliances of the KR-270-like robot (cast aluminium-alloy
    tubes, E = 70 GPa)."""
    E, nu = 7.0e10, 0.33
    return {
        "link_2": beam_compliance(1.150, E, nu, 0.30, 0.26),
        "link_3": beam_compliance(0.600, E, nu, 0.22, 0.18),
        "link_4": beam_compliance(0.600, E, nu, 0.18, 0.15),
    }


def kr270_truth(
    joints: bool = True, links: bool = True, compensator: bool = True, offset: Sequence[float] | None = None
) -> list[dict]:
    """Effect tables (with values) of the KR-270-like truth."""
    eff = []
    if joints:
        for j, c in zip(KR270_JOINTS, KR270_JOINT_C):
            eff.append({"kind": "joint", "target": j["name"], "value": c})
    if links:
        for name, C in kr270_links().items():
            eff.append({"kind": "link", "target": name, "value": C.tolist()})
    if compensator:
        eff.append({"kind": "gravity_compensator", "target": "joint_a2", **KR270_COMPENSATOR})
    if offset is not None:
        eff.append({"kind": "point_offset", "r": list(offset)})
    return eff


def random_postures(n: int, ranges: Sequence[Sequence[float]] | np.ndarray, rng: np.random.Generator) -> np.ndarray:
    lo = np.array([r[0] for r in ranges])
    hi = np.array([r[1] for r in ranges])
    return lo + (hi - lo) * rng.random((n, len(ranges)))


def make_loads(
    kind: str,
    n: int,
    rng: np.random.Generator,
    force: float = 2500.0,
    moment: float = 300.0,
    Rtool: np.ndarray | None = None,
    mass_offset: Sequence[float] = (0.0, 0.0, 0.2),
) -> np.ndarray:
    """n wrenches (n, 6) at the tool origin, base axes.

    kind ``random``: force of magnitude ``force`` in a random direction and a
    random moment up to ``moment``; ``gravity``: a weight (0, 0, -force) hung
    at ``mass_offset`` (tool frame), so only forces along -z and the moment
    of that offset (klimchik's gravity-based loading).
    """
    if kind == "random":
        f = rng.normal(size=(n, 3))
        f *= force / np.linalg.norm(f, axis=1, keepdims=True)
        m = rng.uniform(-moment, moment, size=(n, 3))
        return np.hstack([f, m])
    if kind == "gravity":
        f = np.tile([0.0, 0.0, -force], (n, 1))
        c = np.einsum("nij,j->ni", Rtool, np.asarray(mass_offset, float))
        return np.hstack([f, np.cross(c, f)])
    raise InputError(f"unknown load kind {kind!r}; choose random or gravity")


def synthesize(
    joints: list[dict] | Path | str,
    truth: list[dict],
    n_configs: int = 30,
    loads: str = "random",
    loads_per_config: int = 3,
    markers: npt.ArrayLike = ((0.0, 0.0, 0.25),),
    sigma: float = 2e-5,
    sigma_rotation: float | None = None,
    replicates: int = 1,
    ranges: npt.ArrayLike | None = None,
    force: float = 2500.0,
    moment: float = 300.0,
    seed: int | np.random.Generator = 0,
    workdir: Path | str | None = None,
    tool_frame: str = "tool0",
) -> tuple[Chain, Model, Measurements]:
    """Measurement rows of ``truth`` on the robot ``joints``.

    Returns (chain, truth_model, measurements). Each configuration gets
    ``loads_per_config`` wrenches; each wrench is measured at every marker,
    ``replicates`` times (independent noise), so there are
    n_configs * loads_per_config * len(markers) * replicates rows.
    """
    n_configs = V.count(n_configs, "n_configs", 1, MAX_ROWS)
    loads_per_config = V.count(loads_per_config, "loads_per_config", 1, MAX_ROWS)
    replicates = V.count(replicates, "replicates", 1, 1000)
    markers = V.array(markers, "markers", (None, 3), "position", min_rows=1)
    nrows = n_configs * loads_per_config * markers.shape[0] * replicates
    if nrows > MAX_ROWS:
        raise InputError(f"n_configs x loads_per_config x markers x replicates = {nrows} rows; at most {MAX_ROWS}")
    sigma = V.number(sigma, "sigma", "sigma_position", lo=0.0)
    if sigma_rotation is not None:
        sigma_rotation = V.number(sigma_rotation, "sigma_rotation", "sigma_rotation", lo=0.0)
    force = V.number(force, "force", "force", lo=0.0, lo_open=True)
    moment = V.number(moment, "moment", "moment", lo=0.0)
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        V.count(seed, "seed", 0)
    rng = np.random.default_rng(seed)
    tmp = Path(workdir or tempfile.mkdtemp(prefix="stiffkit_synth_"))
    tmp.mkdir(parents=True, exist_ok=True)
    if isinstance(joints, (str, Path)):  # an existing URDF: copy it
        text = read_text(joints, "URDF")
        if Path(joints).resolve() != (tmp / "robot.urdf").resolve():
            atomic_write_text(tmp / "robot.urdf", text)
        chain = load_chain(tmp / "robot.urdf", "base_link", tool_frame)
    else:
        atomic_write_text(tmp / "robot.urdf", urdf_text("synthetic", joints))
        chain = load_chain(tmp / "robot.urdf", "base_link", joints[-1]["child"])
    dof = chain.dof
    ranges = ranges or [(-math.pi, math.pi)] * dof
    r = V.array(ranges, "ranges", (dof, 2), "angle")
    if np.any(r[:, 0] > r[:, 1]):
        k = int(np.argmax(r[:, 0] > r[:, 1]))
        raise InputError(f"ranges[{k}] = {list(r[k])}: the lower bound exceeds the upper")
    Qc = random_postures(n_configs, ranges, rng)
    Rt = np.array([chain.forward(q)[0] for q in Qc])
    rows_q, rows_w, rows_p, rows_c = [], [], [], []
    for i in range(n_configs):
        W = make_loads(loads, loads_per_config, rng, force, moment, np.repeat(Rt[i : i + 1], loads_per_config, 0))
        for k in range(loads_per_config):
            for mk in markers:
                for _ in range(replicates):
                    rows_q.append(Qc[i])
                    rows_w.append(W[k])
                    rows_p.append(mk)
                    rows_c.append(f"c{i + 1}")
    n = len(rows_q)
    meas = Measurements(
        q=np.array(rows_q),
        w=np.array(rows_w),
        p=np.array(rows_p, float),
        d=np.zeros((n, 3)),
        r=None if sigma_rotation is None else np.zeros((n, 3)),
        config=rows_c,
        lines=list(range(2, n + 2)),
        path="synthetic",
    )
    truth_model = model_from_tables(chain, truth, where="truth")
    pb = Problem(truth_model, meas)
    pred, _ = pb.evaluate(np.zeros(0), jac=False)
    meas.d = pred[0:3].T + sigma * rng.normal(size=(n, 3))
    if sigma_rotation is not None:
        meas.r = pred[3:6].T + sigma_rotation * rng.normal(size=(n, 3))
    return chain, truth_model, meas


def strip_values(effects: list[dict]) -> list[dict]:
    """The effect tables without their values (what a user would identify)."""
    out = []
    for e in effects:
        e2 = {k: v for k, v in e.items() if k not in ("value", "k_s", "r", "rpy")}
        if e2["kind"] in ("link", "base", "tool") and "template" not in e2:
            e2["template"] = "full"
        out.append(e2)
    return out


def check_out_folder(
    out: Path | str, files: Sequence[str], force: bool = False, inputs: Sequence[Path | str] = ()
) -> Path:
    """The folder ``synth`` writes ``files`` into, checked before any work:
    a folder (or none yet) that can be written; none of ``files`` there
    already (the user's data) unless ``force``; none of them one of the
    ``inputs`` (the truth model and its URDF), even with ``force``
    (``stiffkit synth --overwrite``).
    InputError naming the folder and the files."""
    out = Path(out)
    if not str(out).strip():
        raise InputError("--out: empty folder name")
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: a file, not a folder")
    check_folder(out, "--out")
    targets = [out / f for f in files]
    for t in targets:
        for src in inputs:
            s = Path(src)
            if (t.exists() and s.exists() and os.path.samefile(t, s)) or t.resolve() == s.resolve():
                raise InputError(
                    f"--out {out}: would overwrite the truth model file {s}, an input; choose another folder"
                )
    there = [t.name for t in targets if t.exists() or t.is_symlink()]
    if there and not force:
        raise InputError(
            f"--out {out}: holds {', '.join(there)} already; choose another folder, or give --overwrite to replace "
            f"{'it' if len(there) == 1 else 'them'}"
        )
    for t in targets:
        check_output(t, "--out")
    return out


def plan_loads_toml(kind: str, force: float, moment: float) -> str:
    """The [plan] loads table of a synthetic model file (``stiffkit plan``'s
    (posture, load) candidates): the loads of the data's kind along the base
    axes, force ``force`` (N) and moment ``moment`` (N m); ``gravity``: the
    weight alone (its moment depends on the posture)."""
    f, m = float(force), float(moment)
    if kind == "gravity":
        rows = [[0.0, 0.0, -f, 0.0, 0.0, 0.0]]
    else:
        rows = [[0.0, 0.0, -f, 0.0, 0.0, 0.0], [f, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, f, 0.0, 0.0, 0.0, 0.0]]
        if m > 0:
            rows += [[0.0, 0.0, 0.0, m, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, m, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, m]]
    text = ", ".join("[" + ", ".join(f"{v:.17g}" for v in r) + "]" for r in rows)
    return (
        "\n# the loads you can apply (N, N m at the tool, base axes), for `stiffkit plan`: edit to your setup\n"
        f"[plan]\nloads = [{text}]\n"
    )


def write_synth(
    outdir: Path | str,
    joints: list[dict] | Path | str,
    truth: list[dict],
    fit_effects: list[dict],
    declare_sigma: bool = True,
    **kw: object,
) -> Path:
    """Write robot.urdf, model.toml, truth.toml and measurements.csv to outdir."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    chain, truth_model, meas = synthesize(joints, truth, workdir=out, **kw)
    sigma = kw.get("sigma", 2e-5)
    sr = kw.get("sigma_rotation")
    tool = kw.get("tool_frame", "tool0") if isinstance(joints, (str, Path)) else joints[-1]["child"]
    atomic_write_text(
        out / "model.toml",
        model_toml(fit_effects, sigma if declare_sigma and sigma > 0 else None, tool_frame=tool, sigma_rotation=sr)
        + plan_loads_toml(kw.get("loads", "random"), kw.get("force", 2500.0), kw.get("moment", 300.0)),
    )
    atomic_write_text(
        out / "truth.toml", model_toml(truth, sigma if sigma > 0 else None, tool_frame=tool, sigma_rotation=sr)
    )
    write_measurements(out / "measurements.csv", meas)
    return out


def synth_kr270(
    out: Path | str,
    links: bool = True,
    compensator: bool = True,
    offset: Sequence[float] | None = None,
    fit_effects: list[dict] | None = None,
    **kw: object,
) -> Path:
    """Python face of ``stiffkit synth kr270``: the KR-270-like truth, data
    and files in ``out`` (fit_effects default: joints only, the paper's J1)."""
    kw.setdefault("ranges", KR270_RANGES)
    truth = kr270_truth(links=links, compensator=compensator, offset=offset)
    fit_effects = fit_effects if fit_effects is not None else [{"kind": "joint", "target": "all"}]
    return write_synth(out, KR270_JOINTS, truth, fit_effects, **kw)
