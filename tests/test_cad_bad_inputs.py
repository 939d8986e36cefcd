"""Bad face selectors and CAD parts: one clear line naming the key, what
was wrong and the nearest candidates (issue 18); exit status 2 on the CLI."""

from __future__ import annotations

import re

import pytest
from _cad_parts import PLATE, plate_geo, plate_step, shell_step
from test_fea_cli import assert_clean_error, stiffkit

from stiffkit.errors import InputError
from stiffkit.fea.config import ConfigError, parse_link
from stiffkit.fea.facesets import resolve_job_sets
from stiffkit.fea.solve import mesh_job, support_and_load
from stiffkit.meshing import MeshError
from stiffkit.meshing.gmsh_mesh import cad_faces

(X1, Y1), R1 = PLATE["holes"][0]


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    return plate_step(tmp_path_factory.mktemp("plate") / "plate.step")


def cfg(part, support=None, load=None, **extra):
    c = {
        "geometry": {"step": str(part), "units": "mm"},
        "material": {"E": 2.0e11, "nu": 0.3},
        "support": support or {"plane": "x-min"},
        "load": load or {"cylinder": {"axis": [0, 0, 1], "point": [X1, Y1, 0.0], "radius": R1}},
        "mesh": {"size": 10.0, "features": False},
    }
    c.update(extra)
    return c


def resolve(part, **kw):
    return resolve_job_sets(parse_link(cfg(part, **kw), "bad.toml"))


def test_cylinder_radius_matching_no_face_lists_the_nearest_radii(plate):
    with pytest.raises(ConfigError) as e:
        resolve(plate, load={"cylinder": {"axis": [0, 0, 1], "point": [X1, Y1, 0.0], "radius": 6.0}})
    msg = str(e.value)
    assert "bad.toml: [load] cylinder" in msg and "radius 6 matches no cylindrical face" in msg
    assert "nearest radii: 5, 8 mm" in msg


def test_cylinder_off_axis_lists_the_candidate_faces(plate):
    with pytest.raises(ConfigError) as e:
        resolve(plate, load={"cylinder": {"axis": [0, 0, 1], "point": [X1 + 3, Y1, 0.0], "radius": R1}})
    msg = str(e.value)
    assert "no cylindrical face of that radius lies on this axis" in msg
    assert re.search(r"faces of radius 5: face \d+ \(Cylinder, area 628\.3", msg), msg
    with pytest.raises(ConfigError, match="lies on this axis"):
        resolve(plate, load={"cylinder": {"axis": [1, 0, 0], "point": [X1, Y1, 0.0], "radius": R1}})


def test_selectors_that_match_nothing_name_the_nearest_faces(plate):
    with pytest.raises(ConfigError, match=r"\[load\] point = \[50.0, 20.0, 10.0\]: no face passes within .* nearest"):
        resolve(plate, load={"point": [50.0, 20.0, 10.0]})  # inside the material
    with pytest.raises(ConfigError, match=r"\[load\] face = 99: the part has no face 99 \(its faces are 1\.\.8"):
        resolve(plate, load={"face": 99})
    with pytest.raises(ConfigError, match=r"\[load\] box = .*: no face lies wholly inside the box .* nearest: face"):
        resolve(plate, load={"box": [40.0, 10.0, 5.0, 60.0, 30.0, 15.0]})
    with pytest.raises(ConfigError, match=r"\[load\] group = 'bore': no such group; named groups of the part: none"):
        resolve(plate, load={"group": "bore"})


def test_group_misspelt_in_a_geo_gets_a_suggestion(tmp_path):
    geo = plate_geo(tmp_path / "plate.geo")
    with pytest.raises(ConfigError, match=r"group = 'bore' \(did you mean 'bores'\?\): no such group; named groups"):
        resolve(geo, load={"group": "bore"})


def test_load_and_clamp_sets_that_share_nodes(plate):
    """The end face x = 0 and the side y = 0 meet along an edge."""
    job = parse_link(cfg(plate, support={"plane": "x-min"}, load={"point": [50.0, 0.0, 10.0]}), "bad.toml")
    cad = resolve_job_sets(job)
    mesh = mesh_job(job)
    with pytest.raises(MeshError, match=r"\[load\] point \[50.0, 0.0, 10.0\] and \[support\] plane 'x-min' share \d+ "):
        support_and_load(job, mesh, cad)
    with pytest.raises(ConfigError, match=r"both select CAD face\(s\) \[\d+\]"):
        resolve(plate, support={"point": [0.0, 20.0, 10.0]}, load={"point": [0.0, 10.0, 5.0]})


@pytest.mark.parametrize(
    "load, needle",
    [
        ({"cylinder": {"axis": [0, 0, 0], "point": [0, 0, 0], "radius": 1.0}}, "not the zero vector"),
        ({"cylinder": {"axis": [0, 0, 1], "point": [0, 0, 0]}}, "radius is missing"),
        ({"cylinder": {"axis": [0, 0, 1], "point": [0, 0, 0], "radius": -1.0}}, "radius = -1.0 must be positive"),
        ({"cylinder": {"axis": [0, 0, 1], "point": [0, 0, 0], "radius": 1.0, "radus": 2}}, "unknown key(s) radus"),
        ({"face": 0}, "a CAD face id, an integer >= 1"),
        ({"face": "3"}, "a CAD face id"),
        ({"point": [1.0, 2.0]}, "3 numbers"),
        ({"box": [1, 0, 0, 0, 1, 1]}, "each min <= max"),
        ({"group": ""}, "the name of a group"),
        ({"plane": "cylinder"}, "choose one of x-min"),
        ({"face": []}, "give at least one"),
        ({"reference_point": [1.0, 0.0, 0.0]}, "[load] selects no face"),
    ],
)
def test_malformed_selectors(plate, load, needle):
    with pytest.raises(InputError) as e:
        parse_link(cfg(plate, load=load), "bad.toml")
    assert needle in str(e.value) and "bad.toml: [load]" in str(e.value)


def test_step_without_solids(tmp_path):
    shell = shell_step(tmp_path / "shell.step")
    with pytest.raises(MeshError, match=r"shell.step: not a solid: the geometry holds no closed volume \(1 surface"):
        cad_faces({"step": str(shell)}, "mm")
    assert_clean_error(stiffkit("link", "--list-faces", shell), "not a solid", "1 surface(s)")


def test_cli_selector_error_and_list_faces(plate, tmp_path):
    p = tmp_path / "l.toml"
    p.write_text(
        f'[geometry]\nstep = "{plate}"\nunits = "mm"\n[material]\nE = 2e11\nnu = 0.3\n[support]\nplane = "x-min"\n'
        f"[load]\ncylinder = {{axis = [0, 0, 1], point = [{X1}, {Y1}, 0], radius = 4.5}}\n[mesh]\nsize = 10.0\n"
    )
    assert_clean_error(stiffkit("link", p, "--no-cache"), "[load] cylinder", "nearest radii: 5, 8 mm")
    out = stiffkit("link", "--list-faces", plate)
    assert out.returncode == 0, out.stderr
    assert "8 face(s), lengths in mm" in out.stdout
    rows = [ln.split() for ln in out.stdout.splitlines() if re.match(r"^\s+\d+\s+(Plane|Cylinder)", ln)]
    assert len(rows) == 8 and sorted(float(r[-1]) for r in rows if r[1] == "Cylinder") == [5.0, 8.0]
    assert_clean_error(stiffkit("link", "--list-faces", tmp_path / "x.stp"), "file not found")
    assert_clean_error(stiffkit("link", "--list-faces", p), "unknown CAD format '.toml'")
