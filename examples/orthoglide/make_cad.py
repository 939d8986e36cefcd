"""Approximate CAD of three Orthoglide links (Pashkevich et al. 2009, s5,
Fig. 4, Table 7), built with Gmsh's OpenCASCADE kernel and written as STEP
(millimetres). Run from anywhere:  python examples/orthoglide/make_cad.py

The shapes are approximations chosen to resemble the prototype's parts
(the paper gives L = 310 mm, d = 100 mm, r = 31 mm but no drawings):

bar.step   parallelogram bar: a tube 16/12 mm between two end lugs
           24 x 20 x 14 mm with a 8 mm joint bore; 334 mm over the lugs
axle.step  parallelogram axle: a 21/15 mm steel tube, 50 mm long, with a
           40 x 6 mm flange at the clamped end
foot.step  foot: a 110 x 40 x 20 mm aluminium block with a 60 x 24 mm
           lightening window through its thickness and a 12 mm bore
Each LINK.toml beside it carries the single-beam approximation of Table 7
in its [approximation] section.
"""

from pathlib import Path

import gmsh

HERE = Path(__file__).resolve().parent


def bar(occ):
    tube = occ.addCylinder(12.0, 0, 0, 310.0, 0, 0, 8.0)
    bore = occ.addCylinder(12.0, 0, 0, 310.0, 0, 0, 6.0)
    lug1 = occ.addBox(0.0, -10.0, -7.0, 24.0, 20.0, 14.0)
    lug2 = occ.addBox(310.0, -10.0, -7.0, 24.0, 20.0, 14.0)
    body, _ = occ.fuse([(3, tube)], [(3, lug1), (3, lug2)])
    body, _ = occ.cut(body, [(3, bore)])
    h1 = occ.addCylinder(12.0, 0, -8.0, 0, 0, 16.0, 4.0)
    h2 = occ.addCylinder(322.0, 0, -8.0, 0, 0, 16.0, 4.0)
    occ.cut(body, [(3, h1), (3, h2)])


def axle(occ):
    tube = occ.addCylinder(0.0, 0, 0, 50.0, 0, 0, 10.5)
    flange = occ.addCylinder(0.0, 0, 0, 6.0, 0, 0, 20.0)
    body, _ = occ.fuse([(3, tube)], [(3, flange)])
    bore = occ.addCylinder(-1.0, 0, 0, 52.0, 0, 0, 7.5)
    occ.cut(body, [(3, bore)])


def foot(occ):
    block = occ.addBox(0.0, -20.0, -10.0, 110.0, 40.0, 20.0)
    window = occ.addBox(25.0, -12.0, -11.0, 60.0, 24.0, 22.0)
    body, _ = occ.cut([(3, block)], [(3, window)])
    bore = occ.addCylinder(100.0, 0, -11.0, 0, 0, 22.0, 6.0)
    occ.cut(body, [(3, bore)])


def main():
    for name, build in (("bar", bar), ("axle", axle), ("foot", foot)):
        gmsh.initialize(readConfigFiles=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add(name)
            build(gmsh.model.occ)
            gmsh.model.occ.synchronize()
            assert len(gmsh.model.getEntities(3)) == 1, name
            out = HERE / f"{name}.step"
            gmsh.write(str(out))
            print(f"wrote {out}")
        finally:
            gmsh.finalize()


if __name__ == "__main__":
    main()
