"""The packed tree model (bindings/tree.py ``pack``, core/sk_tree_pack.f90):
Python's layout is the core's, the header's offsets frame the arrays, and a
segment of the wrong length is named by the core like any other argument."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from test_tree_core import arm

import stiffkit
from stiffkit._core import tree as core

ROOT = Path(__file__).resolve().parents[1]


def _params(prefix: str) -> dict[str, int]:
    text = (ROOT / "core" / "sk_tree_pack.f90").read_text()
    return {m[0]: int(m[1]) for m in re.findall(rf"\b{prefix}_([a-z0-9]+)\s*=\s*(\d+)\b", text)}


def test_layout_is_the_cores():
    ints, reals, head = _params("pi"), _params("pr"), _params("h")
    assert ints == {k: i + 1 for i, k in enumerate(core.PACK_INTS)}
    assert reals == {k: i + 1 for i, k in enumerate(core.PACK_REALS)}
    assert {k: head[k] for k in core.PACK_COUNTS} == {k: i + 2 for i, k in enumerate(core.PACK_COUNTS)}
    assert head["version"] == 1 and head["ioff"] == 2 + len(core.PACK_COUNTS)
    text = (ROOT / "core" / "sk_tree_pack.f90").read_text()
    assert re.search(rf"pack_version = {core.PACK_VERSION}\b", text)
    # the header's length: h_roff + n_rseg, with h_roff = h_ioff + n_iseg + 1
    assert core.PACK_HEADER == head["ioff"] + len(core.PACK_INTS) + 1 + len(core.PACK_REALS)


def test_offsets_frame_every_array():
    arrays, _theta = arm()
    p = core.pack(2, arrays)
    nc = len(core.PACK_COUNTS)
    assert p.mi[0] == core.PACK_VERSION
    assert list(p.mi[1 : 1 + nc]) == [4, 2, 2, 3, 1, 1, 0]  # nv, nk, ne, nb, ng, nm, nbp
    ioff = p.mi[1 + nc : 1 + nc + len(core.PACK_INTS) + 1] - 1  # 0-based
    roff = p.mi[1 + nc + len(core.PACK_INTS) + 1 : core.PACK_HEADER] - 1
    assert ioff[0] == core.PACK_HEADER and ioff[-1] == p.mi.size and roff[0] == 0 and roff[-1] == p.mr.size
    for k, name in enumerate(core.PACK_INTS):
        np.testing.assert_array_equal(p.mi[ioff[k] : ioff[k + 1]], np.ravel(arrays[name], order="F"))
    for k, name in enumerate(core.PACK_REALS):
        np.testing.assert_array_equal(p.mr[roff[k] : roff[k + 1]], np.ravel(arrays[name], order="F"))


def test_a_short_array_is_named():
    arrays, theta = arm()
    bad = dict(arrays, gcoef=np.zeros(0))
    q = np.zeros((1, 3))
    with pytest.raises(stiffkit.InputError, match=r"argument gcoef: size \(0,\) does not fit"):
        core.poses(core.pack(2, bad), theta, q, None, 0, 1e-9)
    # the same model packed whole evaluates, with the entry points' own checks
    out = core.poses(core.pack(2, arrays), theta, q, None, 0, 1e-9)
    assert out["pa"].shape == (1, 4, 3)
    np.testing.assert_allclose(out["pa"][0, 0], [0.0, 0.0, 0.4])  # the first joint's origin
