"""CalculiX .dat parser: several steps, blank lines, 3-digit exponents,
and fuzzing: any text either parses or raises CcxError, nothing else."""

from __future__ import annotations

import numpy as np
import pytest
from _profiles import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from stiffkit.fea.ccx import CcxError, _number, parse_dat

DAT = """
                        S T E P       1


                                INCREMENT     1


 displacements (vx,vy,vz) for set NALL and time  0.1000000E+01

         1  0.000000E+00  0.000000E+00  0.000000E+00

         2  4.998641E-05  5.715466E-08 -7.298055E-08
        10  0.1234567-100 -1.000000E+00  2.5D-03

                        S T E P       2

 displacements (vx,vy,vz) for set NREF and time  0.2000000E+01
     11  1.0E+00  2.0E+00  3.0E+00
"""


def test_two_steps_blank_lines_three_digit_exponents():
    blocks = parse_dat(DAT)
    assert [b.set for b in blocks] == ["NALL", "NREF"]
    assert [b.time for b in blocks] == [1.0, 2.0]
    a = blocks[0]
    assert a.what == "displacements"
    assert a.ids.tolist() == [1, 2, 10]
    assert a.values[1, 0] == 4.998641e-05
    assert a.values[2, 0] == pytest.approx(0.1234567e-100, rel=1e-12)
    assert a.values[2, 2] == 2.5e-3
    assert blocks[1].values.tolist() == [[1.0, 2.0, 3.0]]


@pytest.mark.parametrize(
    "tok,val",
    [("1.5E-05", 1.5e-05), ("0.1234567-100", 0.1234567e-100), ("-0.5+101", -0.5e101), ("1.0D+03", 1000.0), (".5", 0.5)],
)
def test_fortran_numbers(tok, val):
    assert _number(tok) == pytest.approx(val, rel=1e-15)


def test_bad_values_name_the_line():
    with pytest.raises(CcxError, match="line 3"):
        parse_dat(" displacements (vx,vy,vz) for set NALL and time  0.1E+01\n 1 1.0 2.0 3.0\n 2 1.0 x 3.0\n")
    with pytest.raises(CcxError, match="expected 3 values"):
        parse_dat(" displacements (vx,vy,vz) for set NALL and time 1.0\n 1 1.0 2.0 3.0\n 2 1.0 2.0\n")
    with pytest.raises(CcxError, match="non-finite"):
        parse_dat(" displacements (vx,vy,vz) for set NALL and time 1.0\n 1 NaN 2.0 3.0\n")


LINES = st.one_of(
    st.just(" displacements (vx,vy,vz) for set NALL and time  0.1000000E+01"),
    st.just(""),
    st.builds(
        lambda n, v: f"{n:10d} " + " ".join(f"{x: .6E}" for x in v),
        st.integers(-5, 10**6),
        st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=4),
    ),
    st.text(alphabet="0123456789.eEdD+- \tabcxyz(),", max_size=60),
)


@settings(max_examples=examples(300), deadline=None)
@given(st.lists(LINES, max_size=30))
def test_fuzz_never_crashes(lines):
    try:
        blocks = parse_dat("\n".join(lines))
    except CcxError:
        return
    for b in blocks:
        assert b.ids.shape[0] == b.values.shape[0]
        assert np.isfinite(b.values).all()
