"""A thick-walled tube clamped in the bore seat at one end and loaded
through a pin hole at the other (CAD faces selected by cylinder; Gmsh,
CalculiX and CHOLMOD really run, C3D10 4 mm): against Timoshenko beam
theory with the local terms of its two ends, the field fit against the
reference node, and the rigid against the distributing coupling.

The local terms: the seat lets the tube turn a little where it leaves the
clamp (a root rotation spring c_r) and shear there (c_t), and the pin
deforms the wall around its hole (end compliances at the load point). They
do not depend on the tube's length, so two tubes that differ only in length
differ by Timoshenko's compliance of the extra length, plus c_r's share:
the root rotation c_r * M_root moves the load point by c_r * L per unit
moment and c_r * L^2 per unit force (L: the clamp-to-pin span). c_r is
read from one coupling term (tz under My) of the two tubes; every other
entry is then a prediction.
"""

from __future__ import annotations

import numpy as np
import pytest
from _cad_parts import bored_tube_step

from stiffkit.fea.config import parse_link
from stiffkit.fea.job import run_link
from stiffkit.field.beams import cantilever_compliance, section_properties

DO, DI, DC, LC, DP, E_PIN = 20.0, 10.0, 12.0, 20.0, 5.0, 10.0  # mm: outer, bore, seat, seat length, pin, pin to end
E, NU = 2.0e11, 0.3
LENGTHS = (120.0, 200.0)  # mm


def tube_job(part, L, coupling):
    x_pin = L - E_PIN
    return parse_link(
        {
            "geometry": {"step": str(part), "units": "mm"},
            "material": {"E": E, "nu": NU},
            "support": {"cylinder": {"axis": [1, 0, 0], "point": [0.0, 0.0, 0.0], "radius": DC / 2}},
            "load": {
                "cylinder": {"axis": [0, 0, 1], "point": [x_pin, 0.0, 0.0], "radius": DP / 2},
                "coupling": coupling,
            },
            "mesh": {"size": 4.0, "features": False},  # the plain mesh of the measured figures
        },
        f"tube{L:g}.toml",
    )


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for L in LENGTHS:
        part = bored_tube_step(tmp_path_factory.mktemp("tube") / f"tube{L:g}.step", L, DO, DI, DC, LC, L - E_PIN, DP)
        for coupling in ("rigid", "distributing") if L == LENGTHS[1] else ("rigid",):
            out[L, coupling] = run_link(tube_job(part, L, coupling))
    return out


def timoshenko(L):
    span = (L - E_PIN - LC) * 1e-3
    return span, cantilever_compliance(span, E, NU, section_properties("tube", [DO * 1e-3, DI * 1e-3], NU), True)


def test_reference_point_is_the_pin_axis(runs):
    for (L, _c), res in runs.items():
        np.testing.assert_allclose(res.job.reference_point, [(L - E_PIN) * 1e-3, 0.0, 0.0], atol=1e-8)  # OCC: 1e-6 mm


def test_tube_against_timoshenko_with_its_end_terms(runs):
    (s1, T1), (s2, T2) = timoshenko(LENGTHS[0]), timoshenko(LENGTHS[1])
    C1, C2 = runs[LENGTHS[0], "rigid"].compliance.matrix, runs[LENGTHS[1], "rigid"].compliance.matrix
    dC, dT = C2 - C1, T2 - T1
    # root rotation spring from tz under My (k35 = -L^2/2EI - c_r L + end terms)
    c_r = -(dC[2, 4] - dT[2, 4]) / (s2 - s1)
    assert 0 < c_r < 0.05 * T2[4, 4]  # a small, positive root flexibility
    root = np.zeros((6, 6))
    for i, j, f in [(1, 1, s2**2 - s1**2), (2, 2, s2**2 - s1**2), (1, 5, s2 - s1), (2, 4, -(s2 - s1))]:
        root[i, j] = root[j, i] = c_r * f
    pred = dT + root
    entries = [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (1, 5), (2, 4)]
    err = {f"k{i + 1}{j + 1}": dC[i, j] / pred[i, j] - 1 for i, j in entries}
    print("long minus short tube vs Timoshenko + root rotation:", {k: f"{100 * v:+.3f} %" for k, v in err.items()})
    assert max(abs(v) for v in err.values()) < 0.02
    # the end terms themselves (what a plain Timoshenko model misses) are a few per cent of the long tube's
    local = C2 - T2
    assert 0 < local[1, 1] / C2[1, 1] < 0.15 and 0 < local[4, 4] / C2[4, 4] < 0.1


def test_field_fit_against_reference_node(runs):
    """Rigid: the coupled face moves rigidly, the fit is the reference
    node's motion; distributing: the bore ovalises, fit and work-conjugate
    motion differ but stay within 0.5 % on the diagonal."""
    for key, tol in (((LENGTHS[1], "rigid"), 1e-7), ((LENGTHS[1], "distributing"), 5e-3)):
        res = runs[key]
        d = np.diag(res.compliance.matrix) / np.diag(res.reference_compliance) - 1
        print(key, "fit vs reference node, diagonal:", np.round(100 * d, 4), "%")
        assert np.abs(d).max() < tol
        js = res.to_json()
        assert js["reference_node_difference"] == pytest.approx(d.tolist(), abs=1e-12)


def test_distributing_coupling_is_more_compliant_on_the_diagonal(runs):
    rig = np.diag(runs[LENGTHS[1], "rigid"].compliance.matrix)
    dis = np.diag(runs[LENGTHS[1], "distributing"].compliance.matrix)
    print("distributing / rigid, diagonal:", np.round(dis / rig, 5))
    assert np.all(dis > rig * (1 + 1e-5))


def test_plate_routes_agree_and_distributing_is_softer(tmp_path):
    """The plate of tests/_cad_parts.py clamped in its large bore, loaded on
    its far end face (a point selector): both couplings through both routes
    (six ccx *STEPs, and ccx's K with CHOLMOD), which agree to ccx's 7
    printed digits; the distributing coupling is the softer on every
    diagonal entry."""
    from _cad_parts import plate_step

    part = plate_step(tmp_path / "plate.step")
    diag = {}
    for route in ("matrix", "ccx"):
        for coupling in ("rigid", "distributing"):
            job = parse_link(
                {
                    "geometry": {"step": str(part), "units": "mm"},
                    "material": {"E": E, "nu": NU},
                    "support": {"cylinder": {"axis": [0, 0, 1], "point": [20.0, 20.0, 0.0], "radius": 8.0}},
                    "load": {"point": [100.0, 20.0, 10.0], "coupling": coupling},
                    "mesh": {"size": 8.0, "features": False},
                    "solver": {"route": route},
                },
                "plate.toml",
            )
            res = run_link(job)
            np.testing.assert_allclose(res.job.reference_point, [0.1, 0.02, 0.01], atol=1e-9)
            diag[route, coupling] = np.diag(res.compliance.matrix)
    # the VTU reads back with the sets marked; the faces picture is a PNG
    import meshio

    m = meshio.read(res.write_vtu(tmp_path / "plate.vtu"))
    np.testing.assert_allclose(m.points, res.mesh.nodes, rtol=0, atol=0)
    for name, nodes in (("support_node", res.solution.fixed_nodes), ("load_node", res.solution.load_nodes)):
        np.testing.assert_array_equal(np.nonzero(m.point_data[name])[0] + 1, np.sort(nodes))
    png = res.write_faces_png(tmp_path / "plate.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for coupling in ("rigid", "distributing"):
        np.testing.assert_allclose(diag["ccx", coupling], diag["matrix", coupling], rtol=2e-6)
    assert np.all(diag["matrix", "distributing"] > diag["matrix", "rigid"] * (1 + 1e-5))
