"""klimchik Tables 1 and 2 on the KR-270-like robot (synthetic): the
reduction of the complete model (M1-M5), then J1, J2, C1, C2.

Gravity-based loading as in the paper (a 2.5 kN weight hung 0.2 m along the
tool axis: forces along -z only), partial-pose measurements (three markers),
30 configurations. Models:
  J1  joint compliances only
  J2  joints + the gravity compensator on A2
  C1  complete model (joints + 7 beam links) reduced by M1-M5, no compensator
  C2  C1 + the gravity compensator
Run:  python examples/kr270/table2.py   (about 5 s)
"""

from stiffkit.calib import synth as S
from stiffkit.calib.fit import error_stats, fit
from stiffkit.calib.reduce import format_reduction, reduce_model, reduced_model
from stiffkit.robot.model import model_from_tables

SIGMA = 2e-5
MARKERS = ((0.0, 0.0, 0.25), (0.12, 0.0, 0.2), (0.0, 0.12, 0.2))
GEOM = {k: S.KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")}

chain, truth, meas = S.synthesize(
    S.KR270_JOINTS,
    S.kr270_truth(),
    n_configs=30,
    loads="gravity",
    loads_per_config=1,
    markers=MARKERS,
    sigma=SIGMA,
    ranges=S.KR270_RANGES,
    seed=3,
)
joints = [{"kind": "joint", "target": "all"}]
links = [
    {"kind": "link", "target": ln, "template": "beam"} for ln in ["base_link"] + [f"link_{i}" for i in range(1, 7)]
]
comp = [{"kind": "gravity_compensator", "target": "joint_a2", **GEOM}]
rows = []
for name, effects, reduce in (
    ("J1", joints, False),
    ("J2", joints + comp, False),
    ("C1", joints + links, True),
    ("C2", joints + links + comp, True),
):
    m = model_from_tables(chain, effects, sigma_position=SIGMA)
    if reduce:
        red = reduce_model(m, meas)
        if name == "C1":
            print(format_reduction(red).split("\nM3 merged")[0] + "\n")
        m = reduced_model(m, red)
    res = fit(m, meas)
    rows.append((name, len(res.names), error_stats(res.residuals)))
before = error_stats(meas.d)
print(f"{meas.n} rows, gravity loading, noise {SIGMA * 1e3:g} mm; compliance errors in mm")
print(
    f"{'model':34s}{'params':>7s}"
    + "".join(f"{h:>16s}" for h in ("x MAX/RMS", "y MAX/RMS", "z MAX/RMS", "pos MAX/RMS"))
)


def cells(st):
    c = [(st["axes"][a]["max_m"], st["axes"][a]["rms_m"]) for a in "xyz"]
    c.append((st["max_position_m"], st["rms_position_m"]))
    return "".join(f"{m * 1e3:9.3f}{r * 1e3:7.3f}" for m, r in c)


print(f"{'deflections without compensation':34s}{'':7s}" + cells(before))
for name, n, st in rows:
    frac = 100 * (1 - st["rms_position_m"] / before["rms_position_m"])
    print(f"{name + f' ({frac:.1f} % compensated)':34s}{n:7d}" + cells(st))
