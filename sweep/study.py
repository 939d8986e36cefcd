"""A sweep from a LINK file and ``vary``: plan, run on Dask, gather the table."""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from ..errors import InputError
from ..io import validate as V
from ..io.files import FIGURE_SUFFIXES, check_folder, link_inputs
from . import table as tb
from .plan import Plan, axes_from_python, make_plan, parse_vary
from .runner import check_address, need_dask, plan_estimates, run_jobs

if TYPE_CHECKING:
    from distributed import Client

#: exit status of `stiffkit sweep` when at least one run failed (the others finished)
EXIT_PARTIAL = 3


@dataclass
class SweepResult:
    plan: Plan
    rows: list[dict]
    seconds: float
    meta: dict = field(default_factory=dict)

    @property
    def varied(self) -> list[str]:
        return self.plan.keys

    @property
    def failed(self) -> int:
        return sum(r["status"] != "ok" for r in self.rows)

    @property
    def table(self) -> object:
        return tb.as_table(self.rows, self.varied)


def plan_sweep(link: Path | str | dict, vary: dict | Sequence[str] | str, zip: bool = False) -> Plan:
    """The checked runs (raises PlanError / ConfigError before anything runs)."""
    axes = [parse_vary(v) for v in vary] if _is_cli_list(vary) else axes_from_python(vary)
    return make_plan(link, axes, zipped=zip)


def _is_cli_list(vary: object) -> bool:
    return isinstance(vary, (list, tuple)) and all(isinstance(v, str) for v in vary) and len(vary) > 0


def check_workers(n: object, what: str = "-j") -> int | None:
    if n is None:
        return None
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise InputError(f"{what} {n}: the number of runs in parallel is a whole number >= 1")
    return n


_SIZE = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)\s*([kKmMgGtT]?)i?[bB]?\s*$")


def parse_memory(text: str | float | None) -> float | None:
    """``8G``, ``512M``, ``8000`` (MB) -> MB."""
    if text is None:
        return None
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        v = float(text)
    else:
        m = _SIZE.match(str(text))
        if not m:
            raise InputError(f"--memory {text!r}: a size such as 8G, 512M or 8000 (MB)")
        v = float(m.group(1)) * {"": 1, "k": 1 / 1024, "m": 1, "g": 1024, "t": 1024**2}[m.group(2).lower()]
    if not v > 0:
        raise InputError(f"--memory {text!r}: must be positive")
    return v


def run_sweep(
    link: Path | str | dict,
    vary: dict | Sequence[str] | str,
    *,
    zip: bool = False,
    client: Client | None = None,
    scheduler: str | None = None,
    jobs: int | None = None,
    memory: str | float | None = None,
    cache: Path | str = ".stiffkit-cache",
    progress: bool = False,
    stream: TextIO | None = None,
) -> SweepResult:
    """Plan the sweep, run every run as a Dask task, gather the rows."""
    jobs = check_workers(jobs)
    memory_mb = parse_memory(memory)
    if scheduler and jobs:
        raise InputError("--scheduler and -j: choose one (-j sizes a local cluster)")
    if scheduler:
        check_address(scheduler)
    plan = plan_sweep(link, vary, zip)
    need_dask()
    t0 = time.perf_counter()
    results = run_jobs(
        [r.job for r in plan.runs],
        [f"run {r.index} {r.label}" for r in plan.runs],
        cache,
        client=client,
        scheduler=scheduler,
        workers=jobs,
        memory_mb=memory_mb,
        progress=progress,
        stream=stream,
    )
    rows = [tb.make_row(r.index, r.overrides, res, plan.keys) for r, res in zip_(plan.runs, results)]
    meta = {
        "link": plan.source,
        "vary": [{"keys": [k.text for k in a.keys], "values": a.values} for a in plan.axes],
        "zip": plan.zipped,
        "runs_total": len(rows),
        "runs_ok": sum(r["status"] == "ok" for r in rows),
        "runs_failed": sum(r["status"] != "ok" for r in rows),
        "cache": str(Path(cache).resolve()),
        "scheduler": scheduler or ("client" if client is not None else "local"),
        "wall_time_s": time.perf_counter() - t0,
    }
    return SweepResult(plan=plan, rows=rows, seconds=time.perf_counter() - t0, meta=meta)


zip_ = zip


def sweep(
    link: Path | str | dict,
    vary: dict | Sequence[str] | str,
    client: Client | None = None,
    *,
    zip: bool = False,
    scheduler: str | None = None,
    jobs: int | None = None,
    memory: str | float | None = None,
    cache: Path | str = ".stiffkit-cache",
    progress: bool = False,
) -> object:
    """Run a design sweep of a link; return its table (a pandas DataFrame if
    pandas is installed, else a list of dicts), the same as the CSV of
    ``stiffkit sweep``.

    ``link``: a LINK.toml path or its data as a dict. ``vary``: ``{key:
    values}``, one axis per key (e.g. ``{"mesh.size": [5, 3], "material.E":
    [7e10, 2e11]}``); a value that is itself a dict groups keys that move
    together (``{"length": {"geometry.size.0": [100, 200],
    "load.reference_point.0": [100, 200]}}``); or a list of command-line
    strings ``"KEY=V1,V2"``. The runs are the Cartesian product of the axes,
    or with ``zip=True`` the axes side by side. ``client``: a
    ``distributed.Client`` to run on (left open); else ``scheduler`` (an
    address) or a LocalCluster of ``jobs`` run slots (default: the cores)
    placing runs within ``memory`` (default 90 % of the available memory).
    ``cache``: the FEA cache folder, shared by the workers.
    """
    return run_sweep(
        link,
        vary,
        zip=zip,
        client=client,
        scheduler=scheduler,
        jobs=jobs,
        memory=memory,
        cache=cache,
        progress=progress,
    ).table


def check_outputs(
    varied: list[str],
    x: str | None = None,
    y: str | None = None,
    paths: Iterable[tuple[str, Path | str | None]] = (),
    inputs: Iterable[Path | str] = (),
) -> tuple[str | None, list[str] | None]:
    """--x and --y checked against the varied keys and the result columns;
    every output path (``paths``: (option, path)) checked before the work:
    not an input (``inputs``), its folder writable, --png a figure suffix."""
    cols = tb.columns(varied)
    if x is not None and x not in varied:
        raise InputError(f"--x {x}: plot against a varied key ({', '.join(varied)})")
    ys = None
    if y is not None:
        ys = [s.strip() for s in y.split(",") if s.strip()]
        if not ys:
            raise InputError("--y: empty; e.g. --y k11,k44,cf_max_error")
        text_cols = {"status", "reason", "cached", "element", "route", "cf_kind", "cf_worst", "cache_key", "host"}
        for c in ys:
            if c not in cols or c in text_cols or c in varied:
                raise InputError(
                    f"--y {c}: not a numeric result column; e.g. k11..k66, k11_ci, cf_max_error, "
                    "nodes, wall_s, memory_mb, sigma_m"
                )
    paths = [(opt, p) for opt, p in paths if p]
    for opt, p in paths:
        V.output_path(p, opt, inputs, FIGURE_SUFFIXES if opt == "--png" else None)
    V.distinct_outputs(dict(paths))
    return x, ys


def command(
    link: Path | str,
    vary: Sequence[str],
    *,
    zip: bool = False,
    scheduler: str | None = None,
    jobs: int | None = None,
    memory: str | float | None = None,
    cache: Path | str = ".stiffkit-cache",
    json_out: Path | str | None = None,
    csv_out: Path | str | None = None,
    png_out: Path | str | None = None,
    x: str | None = None,
    y: str | None = None,
    quiet: bool = False,
    dry_run: bool = False,
    out: TextIO | None = None,
    err: TextIO | None = None,
) -> int:
    """`stiffkit sweep`: returns the exit status (0 every run ok, 3 some failed)."""
    out = out or sys.stdout
    err = err or sys.stderr
    check_workers(jobs)
    memory_mb = parse_memory(memory)
    if scheduler and jobs:
        raise InputError("--scheduler and -j: choose one (-j sizes a local cluster)")
    if scheduler:
        check_address(scheduler)
    plan = plan_sweep(link, vary, zip)
    inputs = link_inputs(link) if isinstance(link, (str, Path)) else []
    check_outputs(plan.keys, x, y, [("--json", json_out), ("--csv", csv_out), ("--png", png_out)], inputs)
    if not dry_run:
        check_folder(Path(cache).expanduser(), "--cache")
    if dry_run:
        keys, cached, nodes, mem = plan_estimates([r.job for r in plan.runs], Path(cache).expanduser().resolve())
        print(f"{len(plan.runs)} runs (nothing run: --dry-run)", file=out)
        for r, c, n, m in zip_(plan.runs, cached, nodes, mem):
            print(f"{r.index:4d}  {r.label}   ~{n} nodes, ~{m:.0f} MB{'  (in the cache)' if c else ''}", file=out)
        return 0
    res = run_sweep(
        link,
        vary,
        zip=zip,
        scheduler=scheduler,
        jobs=jobs,
        memory=memory_mb,
        cache=cache,
        progress=not quiet,
        stream=err,
    )
    print(tb.summary(res.rows, res.varied), file=out)
    print(
        f"{len(res.rows) - res.failed} of {len(res.rows)} runs ok, {res.failed} failed; {res.seconds:.1f} s", file=out
    )
    if csv_out:
        print(f"wrote {tb.write_csv(csv_out, res.rows, res.varied)}", file=out)
    if json_out:
        print(f"wrote {tb.write_json(json_out, res.rows, res.varied, res.meta)}", file=out)
    if png_out:
        xk, ys = check_outputs(res.varied, x, y)
        if res.failed < len(res.rows):
            print(f"wrote {tb.plot(png_out, res.rows, res.varied, xk, ys)}", file=out)
        else:
            print(f"no plot: every run failed ({png_out} not written)", file=out)
    return EXIT_PARTIAL if res.failed else 0


__all__ = ["sweep", "run_sweep", "plan_sweep", "command", "SweepResult", "EXIT_PARTIAL", "parse_memory"]
