"""Result rows of a sweep: one per run, the same in Python, CSV and JSON.

Columns, in order: ``run`` (1-based, plan order), one column per varied key
(its dotted name), ``status`` (ok | failed), ``reason`` (one line, failed
runs), ``cached`` (FEA taken from the cache), ``nodes``, ``elements``,
``element`` (C3D4 | C3D10), ``route``, ``wall_s`` (the run's mesh + FEA +
fit; of the original run when cached), ``memory_mb`` (peak resident memory
of the run's processes; of the original run when cached), ``memory_est_mb``
(the estimate the run was placed by), ``sigma_m`` (field-fit noise),
``cf_kind`` (eq22 | approximation | empty), ``cf_max_error`` (largest
relative error of the non-zero elements against the closed form or the
[approximation]), ``cf_worst`` (that element), ``k11`` ... ``k66`` (the
compliance, SI), ``k11_ci`` ... ``k66_ci`` (half-widths of their confidence
intervals), ``cache_key``, ``host``, ``task_s`` (this task's time in this
sweep, process start included), ``start_s``/``end_s`` (seconds from the
start of the sweep).
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

from ..io.files import atomic_write_bytes, save_figure
from .plan import fmt_value

if TYPE_CHECKING:
    from ..fea.outputs import LinkResult

ELEMENTS = [f"k{i + 1}{j + 1}" for i in range(6) for j in range(6)]
HEAD = ["run"]
BODY = [
    "status",
    "reason",
    "cached",
    "nodes",
    "elements",
    "element",
    "route",
    "wall_s",
    "memory_mb",
    "memory_est_mb",
    "sigma_m",
    "cf_kind",
    "cf_max_error",
    "cf_worst",
]
TAIL = ["cache_key", "host", "task_s", "start_s", "end_s"]


def columns(varied: list[str]) -> list[str]:
    return HEAD + list(varied) + BODY + ELEMENTS + [f"{e}_ci" for e in ELEMENTS] + TAIL


def run_fields(res: LinkResult) -> dict:
    """The per-run fields of a finished LinkResult (computed where it ran)."""
    import numpy as np

    c = res.compliance
    st = res.solution.stats
    t = res.solution.timing
    out = {
        "status": "ok",
        "reason": "",
        "cached": bool(res.cached),
        "nodes": int(res.mesh.n_nodes),
        "elements": int(res.mesh.n_elements),
        "element": res.mesh.ccx_type,
        "route": res.solution.route,
        "wall_s": float(t.get("mesh", 0.0) + t.get("fea", 0.0) + res.timing["fit"]),
        "memory_mb": float(max(st.get("ccx_max_rss_mb", 0.0), st.get("python_max_rss_mb", 0.0))),
        "sigma_m": float(c.sigma),
        "cf_kind": "",
        "cf_max_error": None,
        "cf_worst": "",
        "cache_key": res.key,
        "compliance": c.matrix.tolist(),
        "ci": c.ci.tolist(),
        "significant": c.significant.tolist(),
    }
    if res.closed_form is not None:
        err = np.abs(res.closed_form_errors())
        idx = int(np.nanargmax(err))
        out.update(
            cf_kind="approximation" if res.job.approximation is not None else "eq22",
            cf_max_error=float(err.flat[idx]),
            cf_worst=ELEMENTS[idx],
        )
    return out


def failed_fields(reason: str) -> dict:
    return {"status": "failed", "reason": one_line(reason)}


def one_line(text: str, limit: int = 400) -> str:
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


def make_row(run_index: int, overrides: dict, result: dict, varied: list[str]) -> dict:
    """A table row (every column present; None where there is no value)."""
    row = {c: None for c in columns(varied)}
    row["run"] = run_index
    for k in varied:
        row[k] = overrides.get(k)
    for k, v in result.items():
        if k in row:
            row[k] = v
    m, ci = result.get("compliance"), result.get("ci")
    if m is not None:
        for i in range(6):
            for j in range(6):
                row[f"k{i + 1}{j + 1}"] = float(m[i][j])
                row[f"k{i + 1}{j + 1}_ci"] = float(ci[i][j])
    if row["reason"] is None:
        row["reason"] = ""
    return row


def as_table(rows: list[dict], varied: list[str]) -> object:
    """pandas DataFrame when pandas is installed, else the list of dicts."""
    try:
        import pandas as pd
    except ImportError:
        return [dict(r) for r in rows]
    return pd.DataFrame(rows, columns=columns(varied))


# ---------------------------------------------------------------- files


def _atomic_write(path: Path | str, data: bytes) -> Path:
    """Written atomically by io.files (never replacing a device, a FIFO or
    anything but a regular file; errors name ``path``)."""
    return atomic_write_bytes(path, data)


def _csv_cell(v: object) -> object:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)  # every digit: a CSV read back is number for number
    if isinstance(v, list):
        return fmt_value(v)
    return v


def write_csv(path: Path | str, rows: list[dict], varied: list[str]) -> Path:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = columns(varied)
    w.writerow(cols)
    for r in rows:
        w.writerow([_csv_cell(r.get(c)) for c in cols])
    return _atomic_write(path, buf.getvalue().encode())


def _json_safe(v: object) -> object:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_json(path: Path | str, rows: list[dict], varied: list[str], meta: dict) -> Path:
    doc = dict(meta)
    doc["columns"] = columns(varied)
    doc["runs"] = [{k: _json_safe(r.get(k)) for k in columns(varied)} for r in rows]
    return _atomic_write(path, json.dumps(doc, indent=1).encode())


def summary(rows: list[dict], varied: list[str]) -> str:
    """The table printed on the terminal (the full one is the CSV/JSON)."""
    vw = [max(len(k), *(len(_fmt(r[k])) for r in rows)) for k in varied]
    head = f"{'run':>4s} " + " ".join(f"{k:>{w}s}" for k, w in zip(varied, vw))
    head += f" {'status':>6s} {'nodes':>8s} {'wall s':>7s} {'mem MB':>7s} {'cf err %':>9s} {'worst':>5s}"
    head += f" {'k11':>11s} {'k44':>11s}"
    lines = [head]
    for r in rows:
        s = f"{r['run']:4d} " + " ".join(f"{_fmt(r[k]):>{w}s}" for k, w in zip(varied, vw))
        if r["status"] != "ok":
            lines.append(s + f" {'FAILED':>6s}  {r['reason']}")
            continue
        err = "" if r["cf_max_error"] is None else f"{100 * r['cf_max_error']:.4f}"
        s += (
            f" {'ok':>6s} {r['nodes']:8d} {r['wall_s']:7.1f} {r['memory_mb']:7.0f} {err:>9s} "
            f"{r['cf_worst'] or '':>5s} {r['k11']:11.4e} {r['k44']:11.4e}"
        )
        lines.append(s + ("  (cache)" if r["cached"] else ""))
    return "\n".join(lines)


def _fmt(v: object) -> str:
    return "" if v is None else fmt_value(v)


# ---------------------------------------------------------------- plots

DEFAULT_Y = ["k11", "k22", "k33", "k44", "k55", "k66"]


def plot(
    path: Path | str, rows: list[dict], varied: list[str], x: str | None = None, ys: list[str] | None = None
) -> Path:
    """One panel per result column ``ys`` against the varied key ``x``; one
    line per combination of the other varied keys; compliance elements with
    their confidence intervals as error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = x or varied[0]
    ys = ys or (
        DEFAULT_Y + (["cf_max_error"] if any(r.get("cf_max_error") is not None for r in rows) else []) + ["wall_s"]
    )
    ok = [r for r in rows if r["status"] == "ok"]
    others = [k for k in varied if k != x]
    groups: dict[tuple, list[dict]] = {}
    for r in ok:
        groups.setdefault(tuple(_fmt(r[k]) for k in others), []).append(r)
    xs_all = [r[x] for r in ok]
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xs_all)
    cats = sorted({_fmt(v) for v in xs_all}) if not numeric else None
    n = len(ys)
    ncol = min(3, n)
    nrow = (n + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
    for ax, y in zip(axes.ravel(), ys):
        for g, rs in sorted(groups.items()):
            rs = sorted(rs, key=lambda r: r[x] if numeric else _fmt(r[x]))
            xv = [r[x] if numeric else cats.index(_fmt(r[x])) for r in rs]
            yv = [r[y] if r[y] is not None else float("nan") for r in rs]
            if y in ELEMENTS:
                yerr = [r[f"{y}_ci"] for r in rs]
                ax.errorbar(
                    xv,
                    yv,
                    yerr=yerr,
                    fmt="o-",
                    capsize=3,
                    label=" ".join(f"{k}={v}" for k, v in zip(others, g)) or None,
                )
            else:
                ax.plot(xv, yv, "o-", label=" ".join(f"{k}={v}" for k, v in zip(others, g)) or None)
        ax.set_xlabel(x)
        ax.set_ylabel(y)
        if not numeric:
            ax.set_xticks(range(len(cats)), cats)
        vals = [r[y] for r in ok if isinstance(r.get(y), (int, float)) and r[y] is not None]
        if vals and min(vals) > 0 and max(vals) / min(vals) > 20:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        if others and len(groups) > 1:
            ax.legend(fontsize=7)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.suptitle(f"sweep: {len(ok)} of {len(rows)} runs ok")
    fig.tight_layout()
    try:  # the format of the name's suffix (the command checked it)
        return save_figure(fig, path, dpi=90)
    finally:
        plt.close(fig)


__all__ = [
    "columns",
    "run_fields",
    "failed_fields",
    "make_row",
    "as_table",
    "write_csv",
    "write_json",
    "summary",
    "plot",
    "ELEMENTS",
]
