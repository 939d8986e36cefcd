"""Calibration on absolute (tracker) data: time of a fit and of a diagnosis
of every candidate, on the synthetic dual-arm humanoid.

    python bench/bench_absolute.py        (or: make bench BENCH=absolute)

500 postures x 2 hand markers (1000 points), the model tracker + markers +
joint offsets + frame errors + joint compliance under gravity (about 100
identified parameters of 200 declared, the equilibrium iterated). Goals:
fit < 2 s, diagnosis of all candidates < 10 s, on one core. Wall and CPU
time of this process; the machine is shared, so the best of a few runs.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from stiffkit.calib.absolute_diagnose import diagnose_absolute  # noqa: E402
from stiffkit.calib.absolute_fit import fit_absolute  # noqa: E402
from stiffkit.calib.absolute_report import load_absolute  # noqa: E402
from stiffkit.calib.dualarm import synth_dualarm  # noqa: E402

EFFECTS = ["joint_offset", "frame", "joint"]


def timed(fn, repeat: int = 2) -> tuple[float, float, object]:
    best = (float("inf"), float("inf"), None)
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        w, c = time.perf_counter() - w0, time.process_time() - c0
        if w < best[0]:
            best = (w, c, out)
    return best


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        synth_dualarm(out, configs=500, seed=5)
        text = (out / "model.toml").read_text()
        for k in EFFECTS:
            text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
        (out / "model.toml").write_text(text)
        model, data = load_absolute(out / "model.toml", out / "measurements.csv")
        w, c, fit = timed(lambda: fit_absolute(model, data))
        print(
            f"fit: {data.n} points, {len(fit.model.params)} parameters declared, {fit.reduction.kept.size} "
            f"identified, {fit.iterations} LM iterations: {w:.2f} s wall, {c:.2f} s CPU (goal < 2 s); "
            f"RMS {fit.rms_position * 1e3:.3f} mm"
        )
        w, c, fitcv = timed(lambda: fit_absolute(model, data, cv=5), repeat=1)
        print(f"fit with 5-fold CV: {w:.2f} s wall, {c:.2f} s CPU; CV RMS {fitcv.cv['rms_position_m'] * 1e3:.3f} mm")
        w, c, dg = timed(lambda: diagnose_absolute(model, data), repeat=1)
        print(
            f"diagnose: {len(dg.candidates) + len(dg.non_identifiable)} candidates (held-out error of the "
            f"{sum(c.cv_rms_position_m is not None for c in dg.candidates)} leading ones): {w:.2f} s wall, "
            f"{c:.2f} s CPU (goal < 10 s); proposal {dg.proposal.label if dg.proposal else None}"
        )


if __name__ == "__main__":
    main()
