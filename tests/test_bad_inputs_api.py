"""Bad and awkward inputs: the Python API, one row each (the rules every row
obeys and the shared workspace: tests/_bad_inputs.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _bad_inputs import (
    GRID,
    INDEF,
    SEC,
    api,
    check_row,
    kr,
    make_workspace,
    put,
)

import stiffkit as sk
from stiffkit._core.springs import rotate6
from stiffkit.calib.measure import read_measurements
from stiffkit.calib.synth import KR270_JOINTS, kr270_truth, synthesize
from stiffkit.errors import StiffkitError
from stiffkit.fea.config import load_link
from stiffkit.io.files import write_json
from stiffkit.io.linkjson import read_link_compliance
from stiffkit.robot.indices import stiffness_indices
from stiffkit.springs import Joint, Spring, evaluate

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
    # -- the Python API
    api(
        "api-synth-dualarm-sigma-nan",
        lambda ws: sk.calib.synth_dualarm(ws / "da", sigma=float("nan")),
        sk.InputError,
        "sigma = nan must be a finite number",
    ),
    api(
        "api-synth-dualarm-configs-bool",
        lambda ws: sk.calib.synth_dualarm(ws / "da", configs=True),
        sk.InputError,
        "configs = True must be an integer",
    ),
    api(
        "api-synth-dualarm-truth-unknown",
        lambda ws: sk.calib.synth_dualarm(ws / "da", truth="soft"),
        sk.InputError,
        "truth = 'soft': choose one of full, geometric",
    ),
    api(
        "api-fit-field-text",
        lambda ws: sk.fit_field([["a", "b", "c"]] * 4, np.zeros((4, 3)), [0, 0, 0]),
        sk.InputError,
        "must be an array of numbers; got text",
    ),
    api(
        "api-fit-field-ragged",
        lambda ws: sk.fit_field([[0, 0, 0], [1, 0]], np.zeros((2, 3)), [0, 0, 0]),
        sk.InputError,
        "rows of different lengths",
    ),
    api(
        "api-fit-field-2d-points",
        lambda ws: sk.fit_field(np.zeros((5, 2)), np.zeros((5, 2)), [0, 0, 0]),
        sk.InputError,
        "must have shape (n, 3)",
    ),
    api(
        "api-fit-field-nan",
        lambda ws: sk.fit_field(GRID, np.full_like(GRID, np.nan), [0, 0, 0]),
        sk.InputError,
        "displacements[0, 0] is nan",
    ),
    api(
        "api-fit-field-method-number",
        lambda ws: sk.fit_field(GRID, np.zeros_like(GRID), [0, 0, 0], method=4),
        sk.InputError,
        "unknown method 4",
    ),
    api(
        "api-fit-field-trim-text",
        lambda ws: sk.fit_field(GRID, np.zeros_like(GRID), [0, 0, 0], trim="0.1"),
        sk.InputError,
        "trim = '0.1' must be a number",
    ),
    api(
        "api-fit-field-reference-short",
        lambda ws: sk.fit_field(GRID, np.zeros_like(GRID), [0, 0]),
        sk.InputError,
        "reference must be a point",
    ),
    api(
        "api-fit-field-complex",
        lambda ws: sk.fit_field(GRID + 0j, np.zeros_like(GRID), [0, 0, 0]),
        sk.InputError,
        "complex numbers",
    ),
    api(
        "api-fit-field-exact-overflow",
        lambda ws: sk.fit_field(GRID, 1e200 * GRID[:, [1, 0, 2]], [0, 0, 0], method="exact"),
        StiffkitError,
        "did not converge",
    ),
    api(
        "api-fit-field-lin-overflow",
        lambda ws: sk.fit_field(GRID, 1e200 * GRID[:, [1, 0, 2]], [0, 0, 0]),
        sk.InputError,
        "not finite",
    ),
    api(
        "api-fit-fields-shape",
        lambda ws: sk.fit_fields(GRID, np.zeros((2, 5, 3)), [0, 0, 0]),
        sk.InputError,
        "must have shape (m, 27, 3)",
    ),
    api(
        "api-fit-fields-pooled-text",
        lambda ws: sk.fit_fields(GRID, np.zeros((1,) + GRID.shape), [0, 0, 0], pooled="no"),
        sk.InputError,
        "pooled = 'no'",
    ),
    api(
        "api-compliance-fits-ints",
        lambda ws: sk.compliance_from_experiments(np.eye(6), [1, 2, 3, 4, 5, 6]),
        sk.InputError,
        "fits[0] is a int, not a FieldFit",
    ),
    api(
        "api-compliance-five",
        lambda ws: sk.compliance_from_experiments(np.eye(6)[:5], np.zeros((5, 6))),
        sk.InputError,
        "at least 6 experiments",
    ),
    api(
        "api-compliance-confidence",
        lambda ws: sk.compliance_from_experiments(np.eye(6), np.zeros((6, 6)), confidence=99),
        sk.InputError,
        "confidence = 99 must be in (0, 1)",
    ),
    api(
        "api-compliance-wrench-shape",
        lambda ws: sk.compliance_from_experiments(np.eye(3), np.zeros((3, 3))),
        sk.InputError,
        "wrenches must have shape (n, 6)",
    ),
    api(
        "api-section-unknown",
        lambda ws: sk.section_properties("hexagon", [1.0]),
        sk.InputError,
        "unknown section 'hexagon'",
    ),
    api("api-section-count", lambda ws: sk.section_properties("tube", [1.0]), sk.InputError, "takes 2 size(s)"),
    api("api-section-negative", lambda ws: sk.section_properties("square", [-1.0]), sk.InputError, "must be positive"),
    api("api-section-empty", lambda ws: sk.section_properties("square", []), sk.InputError, "takes 1 size(s)"),
    api(
        "api-section-nu",
        lambda ws: sk.section_properties("square", [1.0], 0.6),
        sk.InputError,
        "nu (Poisson's ratio) = 0.6",
    ),
    api(
        "api-cantilever-length",
        lambda ws: sk.cantilever_compliance(-1, 2e11, 0.3, SEC),
        sk.InputError,
        "length = -1 must be positive",
    ),
    api(
        "api-cantilever-E-text",
        lambda ws: sk.cantilever_compliance(1, "steel", 0.3, SEC),
        sk.InputError,
        "E = 'steel' must be a number",
    ),
    api(
        "api-cantilever-section-empty",
        lambda ws: sk.cantilever_compliance(1, 2e11, 0.3, {}),
        sk.InputError,
        "section lacks A",
    ),
    api(
        "api-cantilever-section-list",
        lambda ws: sk.cantilever_compliance(1, 2e11, 0.3, [1, 2]),
        sk.InputError,
        "section must be the dict",
    ),
    api(
        "api-beam-stiffness-E-zero",
        lambda ws: sk.beam_stiffness(1, 0.0, 0.3, SEC),
        sk.InputError,
        "E = 0 must be positive",
    ),
    api("api-normal-quantile", lambda ws: sk.normal_quantile(2.0), sk.InputError, "level = 2 must be in (0, 1)"),
    api("api-load-model-number", lambda ws: sk.load_model(5), sk.InputError, "the path of a model TOML"),
    api("api-load-model-missing", lambda ws: sk.load_model(ws / "none.toml"), sk.InputError, "no such model file"),
    api(
        "api-tool-compliance-shape",
        lambda ws: sk.load_model(kr(ws, "values.toml")).tool_compliance(np.zeros((2, 5))),
        sk.InputError,
        "postures must have shape (N, 6)",
    ),
    api(
        "api-tool-compliance-nan",
        lambda ws: sk.load_model(kr(ws, "values.toml")).tool_compliance([[0, 0, np.nan, 0, 0, 0]]),
        sk.InputError,
        "postures[0, 2] is nan",
    ),
    api(
        "api-tool-compliance-text",
        lambda ws: sk.load_model(kr(ws, "values.toml")).tool_compliance("0,0,0,0,0,0"),
        sk.InputError,
        "got text",
    ),
    api(
        "api-indices-lscale",
        lambda ws: sk.load_model(kr(ws, "values.toml")).stiffness_indices(np.zeros((1, 6)), lscale=-1),
        sk.InputError,
        "lscale = -1 m must be positive",
    ),
    api("api-spring-indefinite", lambda ws: Spring(INDEF), sk.InputError, "negative eigenvalue"),
    api("api-spring-skew", lambda ws: Spring(np.triu(np.ones((6, 6)))), sk.InputError, "is not symmetric"),
    api("api-spring-rot", lambda ws: Spring(np.eye(6), rot=2 * np.eye(3)), sk.InputError, "not a rotation matrix"),
    api("api-spring-kind", lambda ws: Spring(np.eye(6), kind="damping"), sk.InputError, "kind must be"),
    api(
        "api-joint-negative",
        lambda ws: Joint("revolute", [0, 0, 1], compliance=-1.0),
        sk.InputError,
        "compliance = -1 must be >= 0",
    ),
    api("api-joint-type", lambda ws: Joint("ball", [0, 0, 1]), sk.InputError, "must be revolute or prismatic"),
    api("api-joint-axis-text", lambda ws: Joint("revolute", "z"), sk.InputError, "got text"),
    api(
        "api-evaluate-rcond",
        lambda ws: evaluate(Spring(np.eye(6)), rcond=2),
        sk.InputError,
        "rcond = 2 must be in [0, 1)",
    ),
    api(
        "api-evaluate-lscale",
        lambda ws: evaluate(Spring(np.eye(6)), lscale=0),
        sk.InputError,
        "lscale = 0 must be positive",
    ),
    api(
        "api-evaluate-tool", lambda ws: evaluate(Spring(np.eye(6)), tool=[1, 2]), sk.InputError, "tool must have shape"
    ),
    api("api-evaluate-not-a-node", lambda ws: evaluate(np.eye(6)), sk.InputError, "not a spring-tree node"),
    api("api-indices-shape", lambda ws: stiffness_indices(np.eye(5), 1.0), sk.InputError, "stiffness must be (6,6)"),
    api("api-indices-lscale-zero", lambda ws: stiffness_indices(np.eye(6), 0.0), sk.InputError, "lscale must be > 0"),
    api(
        "api-compare-null",
        lambda ws: sk.compare(
            json.loads((ws / "fit.json").read_text()) | {"rms_position_m": None}, str(ws / "fit.json")
        ),
        sk.InputError,
        "'rms_position_m' = None must be a number",
    ),
    api(
        "api-compare-number",
        lambda ws: sk.compare(5, str(ws / "fit.json")),
        sk.InputError,
        "a JSON file name or the dict",
    ),
    api(
        "api-read-measurements-dof",
        lambda ws: read_measurements(kr(ws, "measurements.csv"), 0),
        sk.InputError,
        "dof = 0 must be >= 1",
    ),
    api(
        "api-synthesize-configs",
        lambda ws: synthesize(KR270_JOINTS, kr270_truth(), n_configs=0, workdir=ws / "syn"),
        sk.InputError,
        "n_configs = 0",
    ),
    api(
        "api-synthesize-markers",
        lambda ws: synthesize(KR270_JOINTS, kr270_truth(), markers=[[0, 0]], workdir=ws / "syn"),
        sk.InputError,
        "markers must have shape (n, 3)",
    ),
    api(
        "api-synthesize-ranges",
        lambda ws: synthesize(KR270_JOINTS, kr270_truth(), ranges=[(1, 0)] * 6, workdir=ws / "syn"),
        sk.InputError,
        "the lower bound exceeds the upper",
    ),
    api(
        "api-write-json-nan",
        lambda ws: write_json(ws / "n.json", {"a": [1.0, float("nan")]}),
        StiffkitError,
        "the value at ['a'][1] is nan",
    ),
    api("api-load-link-number", lambda ws: load_link(3), sk.InputError, "the path of a LINK.toml"),
    api(
        "api-link-json-indefinite",
        lambda ws: read_link_compliance(put(ws, "ind.json", json.dumps({"compliance": INDEF}))),
        sk.InputError,
        "negative eigenvalue",
    ),
    api("api-rotate6-shape", lambda ws: rotate6(np.eye(2), np.eye(6)), sk.InputError, "rot must be (3,3)"),
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
