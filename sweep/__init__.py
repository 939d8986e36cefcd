"""Design sweeps and convergence studies on Dask (``dask.distributed``).

``stiffkit.sweep(link, vary={...}, client=None)`` runs the Cartesian product
(or ``zip=True``) of overrides of LINK.toml keys, each run one Dask task, and
returns the table (a pandas DataFrame if pandas is installed, else a list
of dicts), the same as the CSV of ``stiffkit sweep``. Without a client the
runs go to a LocalCluster sized to this machine's cores and memory;
``scheduler="tcp://host:8786"`` runs them on a cluster.

Modules: :mod:`.plan` (the runs from ``--vary``, checked against the
LINK.toml schema), :mod:`.runner` (clusters, memory estimates, tasks,
progress), :mod:`.child` (a fresh process per run), :mod:`.table` (rows,
CSV, JSON, plots). Dask is imported only when a sweep runs.

This module is callable: ``stiffkit.sweep(...)`` is :func:`sweep`.
"""

from __future__ import annotations

import sys
import types
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from distributed import Client

    from .study import SweepResult


def sweep(
    link: Path | str | dict, vary: dict | Sequence[str] | str, client: Client | None = None, **kw: object
) -> object:
    from .study import sweep as _sweep

    return _sweep(link, vary, client=client, **kw)


sweep.__doc__ = """Run a design sweep; see :func:`stiffkit.sweep.study.sweep`."""


def run_sweep(link: Path | str | dict, vary: dict | Sequence[str] | str, **kw: object) -> SweepResult:
    from .study import run_sweep as _run

    return _run(link, vary, **kw)


class _CallableModule(types.ModuleType):
    """``stiffkit.sweep`` is both this package and the function :func:`sweep`."""

    def __call__(
        self, link: Path | str | dict, vary: dict | Sequence[str] | str, client: Client | None = None, **kw: object
    ) -> object:
        return sweep(link, vary, client=client, **kw)


sys.modules[__name__].__class__ = _CallableModule

__all__ = ["sweep", "run_sweep"]
