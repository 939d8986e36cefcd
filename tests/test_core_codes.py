"""The integer codes that Python and the Fortran core share are the core's
own named parameters: each Python table is compared with the
``integer, parameter`` values parsed from the core file that defines them
(law types and chain spring types: tests/test_architecture.py; the tree's
argument codes: tests/test_tree_errors.py; error codes: both)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def fortran_parameters(path: str, prefix: str) -> dict[str, int]:
    """``prefix_name = N`` integer parameters of a core file (continuation
    lines joined), keyed by the name after the prefix."""
    text = re.sub(r"&\s*\n\s*", " ", (ROOT / "core" / path).read_text())
    out = {}
    for line in text.splitlines():
        code = line.split("!")[0]
        if "parameter" not in code or "integer" not in code:
            continue
        for name, value in re.findall(rf"\b{prefix}_(\w+)\s*=\s*(-?\d+)\b", code):
            out[name] = int(value)
    return out


def test_parser_reads_continued_declarations():
    lm = fortran_parameters("sk_lm.f90", "lm")
    assert lm["running"] == 0 and lm["lambda"] == 6  # the second line of a continued declaration
    assert len(fortran_parameters("sk_tree_check.f90", "arg")) >= 40


def test_design_criteria_and_arguments():
    from stiffkit._core.design import CRITERIA, DESIGN_ARGUMENTS

    crit = fortran_parameters("sk_design_base.f90", "crit")
    assert crit == {"d": 1, "a": 2, "task": 3}
    assert CRITERIA == {"D": crit["d"], "A": crit["a"], "task": crit["task"]}
    darg = fortran_parameters("sk_design_base.f90", "darg")
    assert DESIGN_ARGUMENTS == {code: name for name, code in darg.items()}


def test_field_fit_methods():
    from stiffkit.field.fit import METHODS

    m = fortran_parameters("sk_field_fit.f90", "method")
    assert set(m) == {"lin", "svd_plus", "svd_minus", "svd_pm", "exact"}
    assert METHODS == {
        "lin": m["lin"],
        "svd+": m["svd_plus"],
        "svd-": m["svd_minus"],
        "svd+-": m["svd_pm"],
        "svd±": m["svd_pm"],
        "exact": m["exact"],
    }


def test_beam_sections():
    from stiffkit.field.beams import _SECTIONS

    s = fortran_parameters("sk_beams.f90", "section")
    assert s == {"rectangle": 1, "tube": 2}
    # a square is a rectangle, a circle a solid tube (inner diameter 0)
    assert _SECTIONS == {"rectangle": s["rectangle"], "square": s["rectangle"], "tube": s["tube"], "circle": s["tube"]}


def test_spring_tree_program_codes():
    from stiffkit.springs import tree

    ops = fortran_parameters("sk_springs.f90", "op")
    assert {k: getattr(tree, f"OP_{k.upper()}") for k in ops} == ops
    assert set(ops) == {"spring", "joint", "series", "parallel"}
    joints = fortran_parameters("sk_springs.f90", "joint")
    assert tree._JOINT_TYPES == joints == {"revolute": 1, "prismatic": 2}


def test_lm_stopping_reasons():
    from stiffkit._core.calib import LM_CONVERGED, LM_REASONS

    lm = fortran_parameters("sk_lm.f90", "lm")
    lm.pop("nint")  # a state length, not a reason
    assert lm.pop("running") == 0  # the iteration goes on: no reason yet
    assert set(LM_REASONS) == set(lm.values())
    assert {lm[k] for k in ("ftol", "xtol", "gtol", "zero")} == LM_CONVERGED
    for name, text in (("ftol", "ftol"), ("xtol", "xtol"), ("gtol", "gtol"), ("zero", "zero"), ("maxit", "limit")):
        assert text in LM_REASONS[lm[name]], (name, LM_REASONS[lm[name]])


def test_virtual_joint_types_in_the_tree_message():
    vj = fortran_parameters("sk_tree_check.f90", "vj")
    assert vj == {"fixed": 0, "revolute": 1, "prismatic": 2}
    text = (ROOT / "bindings" / "tree_errors.py").read_text()
    assert ", ".join(f"{c} ({n})" for n, c in list(vj.items())[:2]) + f" or {vj['prismatic']} (prismatic)" in text
