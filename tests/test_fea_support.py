"""``[support] coupling``: "rigid" clamps every node of the support set,
"distributing" holds only the set's work-conjugate rigid motion at zero
(beam theory's clamp: the root section free to contract and warp).

Known truths: with that clamp a prismatic bar's axial compliance is L/EA
exactly on any mesh (the uniform stress state is in the element space);
the support's work-conjugate motion of every case is zero; the two FEA
routes agree; a fully clamped root is stiffer (Poisson contraction and
warping held), which beam theory does not contain."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from stiffkit._core.sparse import work_conjugate
from stiffkit.fea import parse_link, run_link
from stiffkit.fea.config import ConfigError, paper_beam
from stiffkit.fea.solve import DistributingSupport
from stiffkit.field.beams import cantilever_compliance, section_properties

pytestmark = pytest.mark.skipif(shutil.which("ccx") is None, reason="needs CalculiX ccx")

L = 200.0  # mm: a short beam, 10 x 10 mm section, C3D10 5 mm (1,838 nodes)


def _beam(route: str, support: str, load: str) -> dict:
    c = paper_beam(5.0, route)
    c["geometry"]["size"] = [L, 10.0, 10.0]
    c["load"].update(reference_point=[L, 0.0, 0.0], coupling=load)
    c["support"]["coupling"] = support
    return c


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    cache = tmp_path_factory.mktemp("support-cache")
    return {
        (route, sup, load): run_link(parse_link(_beam(route, sup, load)), cache_dir=cache)
        for route in ("matrix", "ccx")
        for sup in ("rigid", "distributing")
        for load in ("distributing", "rigid")
    }


@pytest.mark.parametrize("load", ["distributing", "rigid"])
def test_distributing_support_holds_the_mean_motion_only(runs, load):
    r = runs["matrix", "distributing", load]
    sol = r.solution
    job = r.job
    sup = DistributingSupport.of(job, sol.mesh, None, np.asarray(job.reference_point))
    # the six cases' work-conjugate motion of the support set is zero ...
    m = work_conjugate(sup.g, sol.U[:, sup.nodes - 1])
    tip = np.abs(sol.ref_motion).max()
    assert np.abs(m).max() <= 1e-9 * tip
    # ... while its nodes move (they are not clamped): Poisson contraction under Fx
    assert np.abs(sol.U[0, sup.nodes - 1, 1:]).max() > 1e-3 * np.abs(sol.U[0, :, 0]).max()
    # three nodes hold it statically determinately: 3 + 2 + 1 dofs
    assert sorted(len(d) for _n, d in sup.held) == [1, 2, 3] and len({n for n, _d in sup.held}) == 3
    assert r.to_json()["support_coupling"] == "distributing"
    assert "distributing coupling" in r.to_json()["boundary_condition"]


@pytest.mark.parametrize("support", ["rigid", "distributing"])
@pytest.mark.parametrize("load", ["distributing", "rigid"])
def test_the_routes_agree(runs, support, load):
    a = runs["matrix", support, load].compliance.matrix
    b = runs["ccx", support, load].compliance.matrix
    assert np.abs(np.diag(a) / np.diag(b) - 1).max() <= 1e-6
    ra = runs["matrix", support, load].reference_compliance
    rb = runs["ccx", support, load].reference_compliance
    assert np.abs(np.diag(ra) / np.diag(rb) - 1).max() <= 1e-6


def test_beam_theory_clamp_against_the_full_clamp(runs):
    """Distributing support and load: k11 = L/EA to 1e-7 on this coarse
    mesh (the full clamp: 0.14 % stiffer); bending within 0.1 % of
    Timoshenko (eq. 22 plus the shear term, 0.19 % here; 0.058 % measured,
    the mesh has two quadratic elements across); the full clamp is stiffer
    on every diagonal element."""
    d = runs["matrix", "distributing", "distributing"]
    c = runs["matrix", "rigid", "distributing"]
    E, nu = 2.0e11, 0.266
    sec = section_properties("rectangle", [0.01, 0.01], nu)
    eb = cantilever_compliance(L * 1e-3, E, nu, sec)
    ti = cantilever_compliance(L * 1e-3, E, nu, sec, timoshenko=True)
    kd, kc = d.compliance.matrix, c.compliance.matrix
    assert kd[0, 0] / eb[0, 0] - 1 == pytest.approx(0.0, abs=1e-7)
    assert kc[0, 0] / eb[0, 0] - 1 < -1e-3
    for i, j in ((1, 1), (2, 2), (1, 5), (2, 4)):
        assert kd[i, j] / ti[i, j] - 1 == pytest.approx(0.0, abs=1e-3), (i, j)
    assert (np.diag(kc) < np.diag(kd)).all()


def test_support_coupling_is_checked():
    c = _beam("matrix", "glued", "rigid")
    with pytest.raises(ConfigError, match=r"\[support\] coupling"):
        parse_link(c, "beam.toml")
