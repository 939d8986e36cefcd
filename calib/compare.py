"""Side-by-side comparison of two fit results (JSON of `stiffkit fit --json`)."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_json


def load_result(path: Path | str) -> dict:
    """A fit result (JSON of ``stiffkit fit --json``), checked by :func:`check_result`."""
    if not isinstance(path, (str, Path)):
        raise InputError(f"a fit result is a JSON file name or the dict of fit --json, got {type(path).__name__}")
    return check_result(read_json(path, "fit result"), str(path))


def _num(d: dict, key: str, where: str, optional: bool = False) -> float | None:
    if key not in d:
        if optional:
            return None
        raise InputError(f"{where}: missing key {key!r}; expected the output of stiffkit fit --json")
    return V.number(d[key], f"{where}: {key!r}", lo=0.0 if key != "compensated_fraction" else None)


def check_result(d: object, where: str = "fit result") -> dict:
    """The keys compare reads, each of the right type: numbers (finite,
    residuals >= 0), the three axes, the parameters (name and value)."""
    if not isinstance(d, dict):
        raise InputError(
            f"{where}: a JSON object is expected (the output of stiffkit fit --json), got {type(d).__name__}"
        )
    for key in ("rms_position_m", "max_position_m", "compensated_fraction"):
        _num(d, key, where, optional=key == "compensated_fraction")
    axes = d.get("axes")
    if not isinstance(axes, dict):
        raise InputError(f"{where}: 'axes' must be an object with x, y, z; expected the output of stiffkit fit --json")
    for ax in "xyz":
        if not isinstance(axes.get(ax), dict):
            raise InputError(f"{where}: 'axes' has no object {ax!r}")
        for key in ("rms_m", "max_m"):
            _num(axes[ax], key, f"{where}: axes.{ax}")
    params = d.get("parameters")
    if not isinstance(params, list):
        raise InputError(f"{where}: 'parameters' must be a list; expected the output of stiffkit fit --json")
    for i, p in enumerate(params):
        if not isinstance(p, dict) or not isinstance(p.get("name"), str):
            raise InputError(f"{where}: parameters[{i}] must be an object with a 'name' string")
        V.number(p.get("value"), f"{where}: parameters[{i}] ({p['name']}) 'value'")
    if "rank" in d:
        V.number(d["rank"], f"{where}: 'rank'", lo=0, integer=True)
    return d


def compare(
    a: Path | str | dict, b: Path | str | dict, names: tuple[str, str] = ("A", "B"), parameters: bool = True
) -> str:
    """Table of the residuals and parameters of two fits, before/after."""
    A = load_result(a) if not isinstance(a, dict) else check_result(a, str(names[0]))
    B = load_result(b) if not isinstance(b, dict) else check_result(b, str(names[1]))
    w = 14
    lines = [f"{'':30s}{names[0]:>{w}s}{names[1]:>{w}s}{'change':>{w}s}"]

    def row(label: str, va: float, vb: float, scale: float = 1e3, fmt: str = "{:.4f}") -> None:
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
