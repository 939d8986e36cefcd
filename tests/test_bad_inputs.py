"""Bad and awkward inputs over every command and the Python API: the
tables are tests/test_bad_inputs_<topic>.py (one row each; the rules and
the shared workspace in tests/_bad_inputs.py). This file checks that,
together, they are large and cover every command."""

from __future__ import annotations

import test_bad_inputs_api
import test_bad_inputs_calib
import test_bad_inputs_field
import test_bad_inputs_link
import test_bad_inputs_model
import test_bad_inputs_robot
import test_bad_inputs_synth

ROWS = [
    *test_bad_inputs_field.ROWS,
    *test_bad_inputs_model.ROWS,
    *test_bad_inputs_robot.ROWS,
    *test_bad_inputs_synth.ROWS,
    *test_bad_inputs_link.ROWS,
    *test_bad_inputs_calib.ROWS,
    *test_bad_inputs_api.ROWS,
]


def test_the_table_is_large_and_covers_every_command():
    ids = [p.values[0].id for p in ROWS]
    assert len(ids) == len(set(ids)) and len(ids) >= 150
    for prefix in (
        "field",
        "stiffness",
        "urdf",
        "orthoglide",
        "smg",
        "tree",
        "synth",
        "compare",
        "link",
        "fit",
        "diagnose",
        "compensate",
        "convergence",
        "demo",
        "api",
        "app",
    ):
        assert any(i.startswith(prefix + "-") for i in ids), prefix
