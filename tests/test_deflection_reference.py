"""The deflection model (relative data: deflections under known loads)
against reference numbers of the code before its evaluation and its
Levenberg-Marquardt moved into the core (tests/data/deflection_reference.json.gz,
written by tests/data/make_deflection_reference.py): predictions,
Jacobians, fitted values and standard errors, the M1-M5 reduction, the
KR-270 example and the demo's error fall, each to 1e-9 relative."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import _deflection_cases as C
import numpy as np
import pytest

REF = Path(__file__).resolve().parent / "data" / "deflection_reference.json.gz"
RTOL = 1e-9


@pytest.fixture(scope="module")
def reference():
    with gzip.open(REF, "rt", encoding="utf-8") as f:
        return json.load(f)["cases"]


def _close(key, got, want):
    if isinstance(want, np.ndarray) and want.dtype == bool:
        np.testing.assert_array_equal(got, want, err_msg=key)
    elif isinstance(want, np.ndarray):
        got = np.asarray(got, float)
        assert got.shape == want.shape, key
        # 1e-9 relative to each number, and to the array's scale for the
        # entries that cancel to (near) zero
        scale = np.abs(want).max() if want.size else 0.0
        np.testing.assert_allclose(got, want, rtol=RTOL, atol=RTOL * 1e-3 * scale, err_msg=key)
    elif isinstance(want, float):
        assert got == pytest.approx(want, rel=RTOL), key
    else:
        assert got == want, key


def _values(key, got, want, names):
    """Fitted values: 1e-9 relative to each, or to the largest of its unit
    (k_s in N/m, offsets in m, compliances) where it is near zero."""
    got = np.asarray(got, float)
    assert got.shape == want.shape, key
    unit = np.array([n.endswith(".k_s") * 1 + n.startswith("point_offset") * 2 for n in names])
    atol = np.zeros(len(names))
    for u in set(unit):
        atol[unit == u] = RTOL * 1e-3 * np.abs(want[unit == u]).max()
    assert np.all(np.abs(got - want) <= RTOL * np.abs(want) + atol), (key, got - want)


@pytest.mark.parametrize("name", sorted(C.CASES))
def test_deflection_reference(name, reference):
    ref = {k: C.decode(v) for k, v in reference[name].items()}
    got = C.compute(name)
    assert sorted(got) == sorted(ref)
    for key, want in ref.items():
        if key in ("fit_values", "fit_std"):
            _values(key, got[key], want, ref["fit_names"])
        elif key == "theta_probe":
            _values(key, got[key], want, ref["names"])
        else:
            _close(key, got[key], want)
