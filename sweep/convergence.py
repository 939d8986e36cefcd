"""Mesh-convergence studies (the paper's Table 5) on the sweep machinery.

Every (order, size) pair is one LINK job run through the cache, so an
interrupted study resumes from the runs already finished. Runs are tasks of
:mod:`.runner` (Dask): a LocalCluster of ``jobs`` run slots placing runs by
their estimated memory, or the cluster at ``scheduler``; each run in a
fresh process of its own. The assessment of the runs (errors against the
closed form or a Richardson extrapolation) is :func:`stiffkit.fea.convergence.assess`.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from ..fea.config import LinkJob
from ..fea.convergence import RunRecord, assess
from .runner import run_jobs

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["run_study"]


def run_study(
    job: LinkJob,
    orders: Iterable[int],
    sizes: Iterable[float],
    cache_dir: str,
    jobs: int = 1,
    progress: bool = True,
    scheduler: str | None = None,
    client: Client | None = None,
    memory_mb: float | None = None,
) -> dict:
    """Run every (order, size) pair, return the table data (see module).
    Runs that fail are left out of the table and listed in ``failed``."""
    pairs = [(int(o), float(s)) for o in orders for s in sizes]
    results = run_jobs(
        [job.with_mesh(order=o, size=s) for o, s in pairs],
        [f"order {o} size {s:g}" for o, s in pairs],
        cache_dir,
        client=client,
        scheduler=scheduler,
        workers=None if scheduler or client else jobs,
        memory_mb=memory_mb,
        progress=progress,
        title="convergence",
    )
    records: list[RunRecord] = []
    failed = []
    for (o, s), r in zip(pairs, results):
        if r["status"] != "ok":
            failed.append({"order": o, "size": s, "reason": r["reason"]})
            continue
        records.append(
            RunRecord(
                order=o,
                size=s,
                nodes=r["nodes"],
                elements=r["elements"],
                seconds=r["wall_s"],
                memory_mb=r["memory_mb"],
                compliance=np.array(r["compliance"]),
                significant=np.array(r["significant"], dtype=bool),
                cached=r["cached"],
                route=r["route"],
            )
        )
    return assess(job, records, failed)
