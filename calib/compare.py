"""Side-by-side comparison of two fit results (JSON of `stiffkit fit --json`)."""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import InputError


def load_result(path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such fit result file")
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not JSON ({exc})") from None
    for key in ("rms_position_m", "max_position_m", "axes", "parameters"):
        if key not in d:
            raise InputError(f"{path}: missing key {key!r}; expected the output of stiffkit fit --json")
    return d


def compare(a, b, names=("A", "B"), parameters: bool = True) -> str:
    """Table of the residuals and parameters of two fits, before/after."""
    A = load_result(a) if not isinstance(a, dict) else a
    B = load_result(b) if not isinstance(b, dict) else b
    w = 14
    lines = [f"{'':30s}{names[0]:>{w}s}{names[1]:>{w}s}{'change':>{w}s}"]

    def row(label, va, vb, scale=1e3, fmt="{:.4f}"):
        ch = f"{100 * (vb / va - 1):+.1f} %" if va else "-"
        lines.append(f"{label:30s}{fmt.format(va * scale):>{w}s}{fmt.format(vb * scale):>{w}s}{ch:>{w}s}")

    for ax in "xyz":
        row(f"{ax} MAX (mm)", A["axes"][ax]["max_m"], B["axes"][ax]["max_m"])
        row(f"{ax} RMS (mm)", A["axes"][ax]["rms_m"], B["axes"][ax]["rms_m"])
    row("positional MAX (mm)", A["max_position_m"], B["max_position_m"])
    row("positional RMS (mm)", A["rms_position_m"], B["rms_position_m"])
    if "compensated_fraction" in A and "compensated_fraction" in B:
        lines.append(
            f"{'compensated fraction':30s}{100 * A['compensated_fraction']:>{w - 2}.1f} %"
            f"{100 * B['compensated_fraction']:>{w - 2}.1f} %"
        )
    lines.append(f"{'parameters':30s}{len(A['parameters']):>{w}d}{len(B['parameters']):>{w}d}")
    if "rank" in A and "rank" in B:
        lines.append(f"{'rank':30s}{A['rank']:>{w}d}{B['rank']:>{w}d}")
    if not parameters:
        return "\n".join(lines)
    pa = {p["name"]: p for p in A["parameters"]}
    pb = {p["name"]: p for p in B["parameters"]}
    allnames = list(pa) + [n for n in pb if n not in pa]
    lines.append("")
    lines.append(f"{'parameter':30s}{names[0]:>{w}s}{names[1]:>{w}s}")
    for n in allnames:
        va = f"{pa[n]['value']:.4e}" if n in pa else "-"
        vb = f"{pb[n]['value']:.4e}" if n in pb else "-"
        lines.append(f"{n:30s}{va:>{w}s}{vb:>{w}s}")
    return "\n".join(lines)
