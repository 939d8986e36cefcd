"""Speed of the diagnose loop on absolute data (issue 16 item 7): the
synthetic dual-arm robot (`stiffkit synth dualarm`: torso with a coupled
pitch, two 7-joint arms, two hand markers) at 500 postures, the loop from
frames only (calib.absolute_diagnose.diagnose_loop: diagnose, append the
proposal or remove what no longer earns its place, then prune).

    python bench/bench_loop_speed.py [POSTURES]

Prints per step: the model's effects, seconds, candidates ranked and the
RMS; then the whole loop's time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from stiffkit.calib.absolute_diagnose import diagnose_absolute  # noqa: E402
from stiffkit.calib.absolute_report import load_absolute  # noqa: E402
from stiffkit.io.tables import read_toml  # noqa: E402
from stiffkit.robot.tree_model import tree_model_from_tables  # noqa: E402


def main(postures: int = 500) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "dualarm"
        subprocess.run(
            [sys.executable, "-m", "stiffkit", "synth", "dualarm", "--out", str(out), "--configs", str(postures)],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        model, data = load_absolute(out / "model.toml", out / "measurements.csv")
        doc = read_toml(out / "model.toml", "model")
        effects = [dict(e) for e in doc.get("effect", [])]

        def model_of(effs: list[dict]):
            return tree_model_from_tables(
                model.tree, effs, where=str(out / "model.toml"), sigma_position=model.sigma_position
            )

        print(f"{data.n} rows, {len(model.tree.joints)} joints; loop from: {[e['kind'] for e in effects]}")
        t_all = time.perf_counter()
        for step in range(10):
            t0 = time.perf_counter()
            dg = diagnose_absolute(model_of(effects), data, prune=step >= 8)
            dt = time.perf_counter() - t0
            what = "adequate"
            if dg.removal is not None:
                what = f"- {dg.removal.label}"
                effects.pop(dg.removal.index)
            elif dg.proposal is not None:
                what = f"+ {dg.proposal.label}"
                effects.append(dict(dg.proposal.effect))
            rms, cv = 1e3 * dg.fit.rms_position, 1e3 * dg.cv_rms_position_m
            print(
                f"step {step + 1}: {dt:6.1f} s  rms {rms:.4f} mm  cv {cv:.4f} mm  "
                f"{len(dg.candidates)} ranked  {dg.verdict:10s} {what}",
                flush=True,
            )
            if what == "adequate":
                break
        print(f"whole loop: {time.perf_counter() - t_all:.1f} s")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
