"""Diagnosis on absolute data when nothing in the catalogue fits: how often
the residual's structure is found, and how often it is claimed on data
that hold only noise.

    python bench/bench_structure.py            (or: make bench BENCH=structure)
    python bench/bench_structure.py 20 10      (control seeds, seeds per effect)

The synthetic dual-arm robot (300 postures, 0.1 mm noise); the model holds
every kind of the truth (joint offsets, frame errors, joint and lateral
compliance) on every joint, without a declared sigma. Data: the truth
alone (control), or the truth with an effect outside the catalogue
(calib.dualarm.add_hidden_effect): an eccentric gear (2 mrad sin 2q on
four joints) or a tracker drift (0.5 mm over the measurement). Each data
set is diagnosed and every proposal appended (at most four) until none is
made; the table counts the final verdicts.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from stiffkit.calib.absolute_diagnose import diagnose_absolute  # noqa: E402
from stiffkit.calib.absolute_report import load_absolute  # noqa: E402
from stiffkit.calib.diagnose import effect_toml  # noqa: E402
from stiffkit.calib.dualarm import add_hidden_effect, synth_dualarm  # noqa: E402

KINDS = ("joint_offset", "frame", "joint", "lateral")
CASES = (("control", None, 0.0, 100), ("eccentric gear", "cyclic", 2e-3, 200), ("tracker drift", "drift", 5e-4, 300))


def one(folder: Path, hidden: str | None, amount: float, seed: int) -> tuple:
    out = synth_dualarm(folder, configs=300, seed=seed)
    text = (out / "model.toml").read_text()
    for k in KINDS:
        text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
    (out / "model.toml").write_text(text)
    if hidden:
        add_hidden_effect(out, hidden, amount, seed + 1)
    added = []
    for _ in range(5):
        model, data = load_absolute(out / "model.toml", out / "measurements.csv")
        dg = diagnose_absolute(model, data)
        if dg.proposal is None or len(added) == 4:
            break
        added.append(dg.proposal.label)
        (out / "model.toml").write_text(
            (out / "model.toml").read_text().rstrip() + "\n\n" + effect_toml(dg.proposal.effect) + "\n"
        )
    st = dg.residual_structure or {}
    return dg, added, st.get("posture", {}).get("p_value"), st.get("order", {}).get("p_value")


def main() -> None:
    args = [int(a) for a in sys.argv[1:] if a.isdigit()]
    n_control = args[0] if args else 10
    n_effect = args[1] if len(args) > 1 else 5
    print(f"{'data':16s}{'seeds':>6s}{'nothing fits':>14s}{'proposals':>11s}{'RMS left, mm':>16s}{'min p':>14s}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, hidden, amount, base in CASES:
            n = n_control if hidden is None else n_effect
            t0 = time.perf_counter()
            fits, props, rms, pmin = 0, 0, [], [1.0, 1.0]
            for seed in range(base, base + n):
                dg, added, pq, po = one(Path(tmp) / f"{label}-{seed}", hidden, amount, seed)
                fits += dg.nothing_fits
                props += len(added)
                rms.append(dg.fit.rms_position * 1e3)
                pmin = [min(pmin[0], pq if pq is not None else 1.0), min(pmin[1], po if po is not None else 1.0)]
            print(
                f"{label:16s}{n:6d}{fits:>9d} / {n:<3d}{props:>10d}{min(rms):>8.3f}-{max(rms):.3f}"
                f"{pmin[0]:>7.3f} {pmin[1]:.3f}   ({time.perf_counter() - t0:.0f} s)",
                flush=True,
            )
    print("min p: the smallest p-value over the seeds of the posture and of the order test")


if __name__ == "__main__":
    main()
