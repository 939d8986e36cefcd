"""Bad and awkward inputs: `stiffkit link`: LINK.toml, options, outputs, and
the FEA on tiny meshes, one row each (the rules every row obeys and the
shared workspace: tests/_bad_inputs.py)."""

from __future__ import annotations

import pytest
from _bad_inputs import (
    BEAM,
    Q0,
    check_row,
    cmd,
    field_args,
    json_link,
    link_with,
    make_workspace,
    put,
    step_link,
    truncated_cache,
)

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
    # -- link: LINK.toml, options and outputs (no FEA)
    cmd("link-missing", lambda ws: ["link", str(ws / "none.toml")], 2, "no such LINK.toml file"),
    cmd("link-not-toml", lambda ws: ["link", put(ws, "l1.toml", "[geometry\n")], 2, "not valid TOML"),
    cmd("link-not-utf8", lambda ws: ["link", put(ws, "l2.toml", b'[geometry]\nunits = "\xb5m"\n')], 2, "not UTF-8"),
    cmd(
        "link-missing-section",
        lambda ws: ["link", link_with(ws, "l3.toml", "[material]\nE = 2.0e11\nnu = 0.3\n", "")],
        2,
        "section [material] is missing",
    ),
    cmd(
        "link-unknown-section",
        lambda ws: ["link", link_with(ws, "l4.toml", "[field]", "[feild]")],
        2,
        "did you mean 'field'?",
    ),
    cmd(
        "link-misspelt-optional-key",
        lambda ws: ["link", link_with(ws, "l5.toml", "size = 5.0", "szie = 5.0")],
        2,
        "[mesh] unknown key(s) szie",
    ),
    cmd(
        "link-misspelt-fit-key",
        lambda ws: ["link", link_with(ws, "l6.toml", "[mesh]", '[fit]\nmethd = "lin"\n[mesh]')],
        2,
        "unknown key(s) methd (did you mean 'method'?)",
    ),
    cmd(
        "link-E-1e300",
        lambda ws: ["link", link_with(ws, "l7.toml", "E = 2.0e11", "E = 1e300")],
        2,
        "is out of range for a Young's modulus E",
    ),
    cmd(
        "link-E-text",
        lambda ws: ["link", link_with(ws, "l8.toml", "E = 2.0e11", 'E = "steel"')],
        2,
        "E = 'steel' must be a number",
    ),
    cmd(
        "link-E-negative",
        lambda ws: ["link", link_with(ws, "l9.toml", "E = 2.0e11", "E = -2.0e11")],
        2,
        "must be positive",
    ),
    cmd(
        "link-E-in-MPa-warns",
        lambda ws: ["link", link_with(ws, "l10.toml", "E = 2.0e11\nnu = 0.3", "E = 2.0e5\nnu = 0.7")],
        2,
        "it looks like N/mm^2 (MPa): give 2e+11 Pa",
        warns=True,
    ),
    cmd(
        "link-nu-half",
        lambda ws: ["link", link_with(ws, "l11.toml", "nu = 0.3", "nu = 0.5")],
        2,
        "nu = 0.5 must be in (-1, 0.5)",
    ),
    cmd(
        "link-density-g-cm3-warns",
        lambda ws: [
            "link",
            link_with(ws, "l12.toml", "nu = 0.3", 'nu = 0.3\ndensity = 7.85\n[solver]\nroute = "matrx"'),
        ],
        2,
        "it looks like g/cm^3",
        warns=True,
    ),
    cmd(
        "link-units-misspelt",
        lambda ws: ["link", link_with(ws, "l13.toml", 'units = "mm"', 'units = "mmm"')],
        2,
        "units = 'mmm' (did you mean 'mm'?)",
    ),
    cmd(
        "link-box-two-sizes",
        lambda ws: ["link", link_with(ws, "l14.toml", "size = [40.0, 10.0, 10.0]", "size = [40.0, 10.0]")],
        2,
        "three positive lengths",
    ),
    cmd(
        "link-box-with-diameter",
        lambda ws: ["link", link_with(ws, "l15.toml", 'units = "mm"', 'units = "mm"\ninner_diameter = 5.0')],
        2,
        "not a key of shape = 'box'",
    ),
    cmd(
        "link-tube-inner-too-big",
        lambda ws: [
            "link",
            link_with(
                ws,
                "l16.toml",
                'shape = "box"\nsize = [40.0, 10.0, 10.0]',
                'shape = "tube"\nlength = 40.0\nouter_diameter = 10.0\ninner_diameter = 12.0',
            ),
        ],
        2,
        "inner_diameter = 12.0 must lie in (0, outer_diameter = 10.0)",
    ),
    cmd(
        "link-reference-two",
        lambda ws: ["link", link_with(ws, "l17.toml", "[40.0, 0.0, 0.0]", "[40.0, 0.0]")],
        2,
        "three coordinates",
    ),
    cmd(
        "link-reference-nan",
        lambda ws: ["link", link_with(ws, "l18.toml", "[40.0, 0.0, 0.0]", "[40.0, nan, 0.0]")],
        2,
        "must be a finite number",
    ),
    cmd(
        "link-amplitudes-five",
        lambda ws: [
            "link",
            link_with(ws, "l19.toml", "reference_point", "amplitudes = [1.0, 1.0, 1.0, 1.0, 1.0]\nreference_point"),
        ],
        2,
        "six positive",
    ),
    cmd(
        "link-amplitudes-negative",
        lambda ws: [
            "link",
            link_with(
                ws, "l20.toml", "reference_point", "amplitudes = [1.0, 1.0, -1.0, 1.0, 1.0, 1.0]\nreference_point"
            ),
        ],
        2,
        "amplitudes Fz = -1 N must be positive",
    ),
    cmd(
        "link-amplitudes-misspelt-auto",
        lambda ws: ["link", link_with(ws, "l21.toml", "reference_point", 'amplitudes = "autoo"\nreference_point')],
        2,
        '"auto" or six positive',
    ),
    cmd(
        "link-cube-without-size",
        lambda ws: ["link", link_with(ws, "l22.toml", 'region = "face"', 'region = "cube"')],
        2,
        "[field] size = 0.0 must be positive",
    ),
    cmd(
        "link-face-with-size",
        lambda ws: ["link", link_with(ws, "l23.toml", 'region = "face"', 'region = "face"\nsize = 3.0')],
        2,
        "is for region",
    ),
    cmd(
        "link-order-three",
        lambda ws: ["link", link_with(ws, "l24.toml", "order = 1", "order = 3")],
        2,
        "order = 3: choose one of 1, 2",
    ),
    cmd(
        "link-order-bool",
        lambda ws: ["link", link_with(ws, "l25.toml", "order = 1", "order = true")],
        2,
        "must be an integer",
    ),
    cmd(
        "link-size-negative",
        lambda ws: ["link", link_with(ws, "l26.toml", "size = 5.0", "size = -5.0")],
        2,
        "must be positive",
    ),
    cmd(
        "link-size-larger-than-part",
        lambda ws: ["link", link_with(ws, "l27.toml", "size = 5.0", "size = 50.0")],
        2,
        "larger than the whole part",
    ),
    cmd(
        "link-size-larger-than-section-warns",
        lambda ws: ["link", link_with(ws, "l28.toml", "size = 5.0", "size = 20.0\n[fit]\ntrim = 0.6")],
        2,
        "less than one element across",
        warns=True,
    ),
    cmd(
        "link-refine-range",
        lambda ws: ["link", link_with(ws, "l29.toml", "size = 5.0", "size = 5.0\nrefine = 1.5")],
        2,
        "refine = 1.5: a size factor in (0, 1)",
    ),
    cmd(
        "link-refine-radius-alone",
        lambda ws: ["link", link_with(ws, "l30.toml", "size = 5.0", "size = 5.0\nrefine_radius = 3.0")],
        2,
        "refine_radius needs refine",
    ),
    cmd(
        "link-across-without-structured",
        lambda ws: ["link", link_with(ws, "l31.toml", "size = 5.0", "size = 5.0\nacross_factor = 0.5")],
        2,
        "needs structured = true",
    ),
    cmd(
        "link-structured-text",
        lambda ws: ["link", link_with(ws, "l32.toml", "size = 5.0", 'size = 5.0\nstructured = "yes"')],
        2,
        "true or false",
    ),
    cmd(
        "link-trim-range",
        lambda ws: ["link", link_with(ws, "l33.toml", "[mesh]", "[fit]\ntrim = 0.6\n[mesh]")],
        2,
        "a fraction in [0, 0.5)",
    ),
    cmd(
        "link-confidence-percent",
        lambda ws: ["link", link_with(ws, "l34.toml", "[mesh]", "[fit]\nconfidence = 99.0\n[mesh]")],
        2,
        "a level in (0, 1)",
    ),
    cmd(
        "link-route-misspelt",
        lambda ws: ["link", link_with(ws, "l35.toml", "[mesh]", '[solver]\nroute = "matrx"\n[mesh]')],
        2,
        "did you mean 'matrix'?",
    ),
    cmd(
        "link-timeout-zero",
        lambda ws: ["link", link_with(ws, "l36.toml", "[mesh]", "[solver]\ntimeout = 0\n[mesh]")],
        2,
        "timeout = 0 s must be positive",
    ),
    cmd(
        "link-tolerance-negative",
        lambda ws: ["link", link_with(ws, "l37.toml", 'plane = "x-min"', 'plane = "x-min"\ntolerance = -1.0')],
        2,
        "tolerance = -1.0 must be positive",
    ),
    cmd(
        "link-same-planes",
        lambda ws: ["link", link_with(ws, "l38.toml", 'plane = "x-max"', 'plane = "x-min"')],
        2,
        "also the support plane",
    ),
    cmd(
        "link-plane-misspelt",
        lambda ws: ["link", link_with(ws, "l39.toml", 'plane = "x-max"', 'plane = "xmax"')],
        2,
        "did you mean 'x-max'?",
    ),
    cmd(
        "link-step-missing",
        lambda ws: [
            "link",
            link_with(ws, "l40.toml", 'shape = "box"\nsize = [40.0, 10.0, 10.0]', 'step = "gone.step"'),
        ],
        2,
        "file not found",
    ),
    cmd(
        "link-section-not-table",
        lambda ws: ["link", put(ws, "l41.toml", "field = 3\n" + BEAM.replace('[field]\nregion = "face"\n', ""))],
        2,
        "[field] must be a table",
    ),
    cmd(
        "link-option-size-zero",
        lambda ws: ["link", str(ws / "beam.toml"), "--size", "0"],
        2,
        "--size = 0 must be positive",
    ),
    cmd(
        "link-option-size-negative",
        lambda ws: ["link", str(ws / "beam.toml"), "--size=-1"],
        2,
        "--size = -1 must be positive",
    ),
    cmd(
        "link-option-size-too-large",
        lambda ws: ["link", str(ws / "beam.toml"), "--size", "100"],
        2,
        "larger than the whole part",
    ),
    cmd(
        "link-size-millions-of-elements",
        lambda ws: ["link", link_with(ws, "l42.toml", "size = 5.0", "size = 0.01")],
        2,
        "[mesh] size: element size 0.01 mm would need about 2.4e+10 tetrahedra",
    ),
    cmd(
        "link-json-duplicate-key",
        lambda ws: [
            "stiffness",
            json_link(ws, put(ws, "dk.json", '{"compliance": 1, "compliance": 2}')),
            "--posture",
            Q0,
        ],
        2,
        "the key 'compliance' appears twice",
    ),
    cmd(
        "field-semicolon-separated",
        lambda ws: field_args(ws, put(ws, "semi.csv", "x;y;z\n1;0;0\n")),
        2,
        "separated by a semicolon",
    ),
    cmd(
        "compare-huge-integer",
        lambda ws: ["compare", put(ws, "c13.json", '{"rms_position_m": 1' + "0" * 400 + "}"), str(ws / "fit.json")],
        2,
        "beyond double precision",
    ),
    cmd("link-option-order", lambda ws: ["link", str(ws / "beam.toml"), "--order", "3"], 2, "invalid choice"),
    cmd(
        "link-json-is-input",
        lambda ws: ["link", str(ws / "beam.toml"), "--json", str(ws / "beam.toml")],
        2,
        "is an input file",
    ),
    cmd(
        "link-vtu-suffix",
        lambda ws: ["link", str(ws / "beam.toml"), "--vtu", str(ws / "o.vtk")],
        2,
        "must end in one of .vtu",
    ),
    cmd(
        "link-png-suffix",
        lambda ws: ["link", str(ws / "beam.toml"), "--png", str(ws / "o.xyz")],
        2,
        "must end in one of .png",
    ),
    cmd(
        "link-json-same-as-png",
        lambda ws: ["link", str(ws / "beam.toml"), "--json", str(ws / "o.png"), "--png", str(ws / "o.png")],
        2,
        "the same file as --json",
    ),
    cmd(
        "link-cache-is-file",
        lambda ws: ["link", str(ws / "beam.toml"), "--cache", str(ws / "fit.json")],
        2,
        "a file, not a folder",
    ),
    # -- link with the FEA (tiny meshes)
    cmd(
        "link-field-cube-covers-clamp",
        lambda ws: [
            "link",
            link_with(ws, "f1.toml", 'region = "face"', 'region = "cube"\nsize = 200.0'),
            "--cache",
            str(ws / "cache"),
        ],
        2,
        "clamped node(s) of the [support] plane",
    ),
    cmd(
        "link-field-layer-covers-clamp",
        lambda ws: [
            "link",
            link_with(ws, "f2.toml", 'region = "face"', 'region = "layer"\nsize = 40.0'),
            "--cache",
            str(ws / "cache"),
        ],
        2,
        "clamped node(s)",
    ),
    cmd(
        "link-step-in-metres-declared-mm-warns",
        lambda ws: ["link", step_link(ws), "--cache", str(ws / "cache")],
        0,
        "is the geometry in metres?",
        warns=True,
    ),
    cmd(
        "link-truncated-cache-entry-is-a-miss",
        lambda ws: ["link", str(ws / "beam.toml"), "--cache", truncated_cache(ws)],
        0,
        "ignoring the unreadable cache entry",
        warns=True,
    ),
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
