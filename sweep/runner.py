"""Runs of a sweep as tasks of a Dask cluster (``dask.distributed``).

Where runs go:

* default: a LocalCluster on this machine, one worker whose threads are the
  run slots (as many as cores, or ``workers``) and which declares the
  machine's memory budget as the Dask resource ``MEMORY`` (bytes: 90 % of
  the memory available when the sweep starts, or ``memory_mb``). The worker
  lives in the calling process (its threads only wait for the runs' own
  processes), so nothing of the caller's ``__main__`` is imported again and
  nothing outlives it;
* ``scheduler="tcp://host:8786"``: a running cluster (``dask scheduler`` +
  ``dask worker``, stiffkit installed on the workers). Workers started with
  ``--resources MEMORY=<bytes>`` get the same placement by memory; without
  it Dask places runs by free threads only.

Every run asks for ``MEMORY`` = its estimated peak memory (from the node
count its mesh will have, :func:`estimate_nodes`, before anything runs), so a
worker starts a run only when it fits beside those already running: two
4 GB runs do not start together on an 8 GB machine. A run estimated above the
whole budget runs alone. Each run is one task; the task runs it in a fresh
process (:mod:`stiffkit.sweep.child`) through the FEA cache in ``cache_dir``
(a folder every worker reaches): a finished run is never computed again, an
interrupted sweep resumes, and runs that share an FEA (differing only in the
fit) wait for the first one and take its result from the cache.

A failed run (mesh, ccx, fit) is a row with status ``failed`` and its
one-line reason; the other runs go on.
"""

from __future__ import annotations

import contextlib
import copy
import logging
import os
import pickle
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import uuid
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from ..errors import StiffkitError, StiffkitWarning
from ..fea.cache import remove_stale_temporaries
from ..fea.job import cache_key, resolve_route
from .estimates import CACHED_MB, estimate_memory_mb, estimate_nodes
from .progress import Progress
from .table import failed_fields, one_line

if TYPE_CHECKING:
    from distributed import Client

    from ..fea.config import LinkJob

#: the Dask worker resource runs are placed by (bytes)
RESOURCE = "MEMORY"
#: seconds to wait for a scheduler to answer
CONNECT_TIMEOUT_S = 3.0
#: fraction of the available memory a LocalCluster hands out
MEMORY_FRACTION = 0.9


class SchedulerError(StiffkitError):
    """No Dask scheduler answers at the address given."""


# ---------------------------------------------------------------- the task (runs on a worker)

_local = threading.local()
_launchers: set = set()  # every launcher of this process
_launchers_lock = threading.Lock()
_stopping = threading.Event()  # set on Ctrl-C: runs in flight are stopped, none start


def _child_env() -> dict:
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(var, "1")  # one core per run: runs share the machine
    env["PYTHONUNBUFFERED"] = "1"
    return env


class _Launcher:
    """A process that has imported what runs need and forks one child per run."""

    def __init__(self, tmp: Path) -> None:
        self.log_path = tmp / f"launcher-{os.getpid()}-{threading.get_ident()}.log"
        log = open(self.log_path, "ab")
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "stiffkit.sweep.child", "serve"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=log,
                env=_child_env(),
                text=True,
                bufsize=1,
            )
        finally:
            log.close()
        with _launchers_lock:
            _launchers.add(self)

    def stop(self) -> None:
        """Stop the launcher and its run (SIGTERM: it stops its child, which stops ccx)."""
        try:
            self.proc.terminate()
        except OSError:
            pass

    def close(self, timeout: float = 5.0) -> None:
        """End an idle launcher (EOF on its stdin) and remove its log."""
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=timeout)
        except Exception:
            self.stop()
            with contextlib.suppress(Exception):
                self.proc.wait(timeout=timeout)
        self.release()
        self.log_path.unlink(missing_ok=True)

    def release(self) -> None:
        """Close this side of the launcher's pipes (no unclosed file left)."""
        for pipe in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(Exception):
                pipe.close()

    def alive(self) -> bool:
        return self.proc.poll() is None

    def run(self, spec: Path, result: Path) -> int | None:
        """Wait status of the child, or None if the launcher is gone."""
        try:
            self.proc.stdin.write(f"{spec}\t{result}\n")
            self.proc.stdin.flush()
            line = self.proc.stdout.readline()
        except (OSError, ValueError):
            return None
        return int(line) if line.strip() else None

    def log_tail(self) -> str:
        try:
            lines = [x for x in self.log_path.read_text(errors="replace").splitlines() if x.strip()]
        except OSError:
            return ""
        return lines[-1] if lines else ""


def stop_local_runs() -> None:
    """Stop the runs in flight in this process's workers and start no more."""
    _stopping.set()
    with _launchers_lock:
        todo = list(_launchers)
        _launchers.clear()
    for la in todo:
        la.stop()
    for la in todo:
        with contextlib.suppress(Exception):
            la.proc.wait(timeout=10)
        la.release()
        la.log_path.unlink(missing_ok=True)


def close_launchers() -> None:
    """End the idle launchers of this process (when its cluster closes)."""
    with _launchers_lock:
        todo = list(_launchers)
        _launchers.clear()
    for la in todo:
        la.close()


def _tmp_root() -> Path:
    root = Path(tempfile.gettempdir()) / f"stiffkit-sweep-{os.getuid()}"
    root.mkdir(parents=True, exist_ok=True)
    return root


def _status_text(code: int) -> str:
    """Why a run's process ended without a result (code: exit code, -N: signal N)."""
    if code < 0:
        name = {9: "SIGKILL: out of memory?", 11: "SIGSEGV: crashed"}.get(-code, f"signal {-code}")
        return f"the run's process was killed ({name})"
    return f"the run's process exited with status {code} and no result"


def _run_in_child(spec_path: Path, result_path: Path) -> tuple[int | None, str]:
    """Run a spec in a fresh process: (exit code or None if stopped, last log line)."""
    if _stopping.is_set():
        return None, ""
    launcher = getattr(_local, "launcher", None)
    if launcher is None or not launcher.alive():
        launcher = _local.launcher = _Launcher(_tmp_root())
    status = launcher.run(spec_path, result_path)
    if status is not None:
        return os.waitstatus_to_exitcode(status), launcher.log_tail()
    launcher.release()
    _local.launcher = None
    if _stopping.is_set():
        return None, ""
    # no launcher: a plain process of its own
    proc = subprocess.run(
        [sys.executable, "-m", "stiffkit.sweep.child", "run", str(spec_path), str(result_path)],
        env=_child_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    return proc.returncode, ((proc.stderr or "").strip().splitlines() or [""])[-1]


def run_task(spec: dict, *_after: object) -> dict:
    """One run on a worker: returns its table fields (never raises for a run
    that fails; ``_after`` are runs whose FEA this one reuses)."""
    import json

    t_start = time.time()
    cache = Path(spec["cache_dir"])
    cache.mkdir(parents=True, exist_ok=True)
    # the run's folder (spec, result, ccx deck and scratch) in the cache folder,
    # like `stiffkit link`'s; kept when the run fails, for inspection
    tmp = Path(tempfile.mkdtemp(prefix="run-", dir=cache))
    try:
        job = spec["job"]
        cad = spec.get("cad")
        if cad is not None and not os.path.isfile(job.geometry["step"]):
            # a worker without the client's files: the CAD travels with the task
            # (the cache key is the file's content hash, not its path)
            p = tmp / ("part" + Path(job.geometry["step"]).suffix)
            p.write_bytes(cad)
            job = copy.deepcopy(job)
            job.geometry["step"] = str(p)
        spec_path, result_path = tmp / "spec.pkl", tmp / "result.json"
        with open(spec_path, "wb") as fh:
            pickle.dump({"job": job, "cache_dir": str(cache), "workdir": str(tmp)}, fh)
        code, tail = _run_in_child(spec_path, result_path)
        if code is None:
            out = failed_fields("interrupted")
        else:
            try:
                out = json.loads(result_path.read_text())
            except (OSError, ValueError):
                out = failed_fields(_status_text(code) + (f"; {tail}" if tail else ""))
    except Exception as exc:  # the task itself must not raise
        out = failed_fields(f"{type(exc).__name__}: {exc}")
    reason = str(out.get("reason", ""))
    if out.get("status") == "failed" and "interrupted" not in reason and str(tmp) in reason:
        # the reason names a file of the run's folder (a ccx log): kept
        for name in ("spec.pkl", "result.json"):
            (tmp / name).unlink(missing_ok=True)
        with contextlib.suppress(OSError):
            tmp.rmdir()
    else:  # done, interrupted, or nothing to inspect (a missing solver, a mesh failure)
        shutil.rmtree(tmp, ignore_errors=True)
    out["host"] = socket.gethostname()
    out["t_start"], out["t_end"] = t_start, time.time()
    return out


# ---------------------------------------------------------------- clients


def default_slots() -> int:
    try:
        from distributed.system import CPU_COUNT

        return max(1, int(CPU_COUNT))
    except ImportError:  # pragma: no cover
        return max(1, len(os.sched_getaffinity(0)))


def default_memory_mb() -> float:
    import psutil

    avail = psutil.virtual_memory().available
    try:
        from distributed.system import MEMORY_LIMIT

        avail = min(avail, MEMORY_LIMIT)
    except ImportError:  # pragma: no cover
        pass
    return MEMORY_FRACTION * avail / 2**20


_ADDRESS = re.compile(r"^(?:(tcp|tls|inproc|ucx|ws|wss)://)?([^\s:/]+|\[[0-9a-fA-F:]+\]):(\d{1,5})$")


def check_address(address: str) -> str:
    """``tcp://host:port`` (``host:port`` means tcp)."""
    m = _ADDRESS.match(address.strip())
    if not m or not 0 < int(m.group(3)) < 65536:
        raise SchedulerError(f"--scheduler {address!r}: write a scheduler address, e.g. tcp://host:8786")
    return address.strip() if m.group(1) else f"tcp://{address.strip()}"


def need_dask() -> None:
    try:
        import distributed  # noqa: F401
    except ImportError as exc:
        raise StiffkitError(
            f"sweeps run on Dask, which is not installed ({exc}); run `make install` or pip install 'stiffkit[sweep]'"
        ) from None


@contextlib.contextmanager
def _quiet_dask() -> Iterator[None]:
    names = [
        "distributed",
        "distributed.comm",
        "distributed.core",
        "distributed.client",
        "distributed.scheduler",
        "distributed.worker",
        "distributed.nanny",
        "tornado",
    ]
    saved = {n: logging.getLogger(n).level for n in names}
    for n in names:
        logging.getLogger(n).setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for n, lv in saved.items():
            logging.getLogger(n).setLevel(lv)


class Where:
    """What the runs run on: a client, its memory placement, a description."""

    def __init__(self, client: Client, budget_mb: float | None, text: str, slots: int) -> None:
        self.client, self.budget_mb, self.text, self.slots = client, budget_mb, text, slots


@contextlib.contextmanager
def open_cluster(
    client: Client | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    memory_mb: float | None = None,
    n_runs: int | None = None,
) -> Iterator[Where]:
    """Yield a :class:`Where`; a cluster made here is closed on the way out
    (also on Ctrl-C), a client given is left open."""
    need_dask()
    from distributed import Client, LocalCluster

    if client is not None:
        yield _describe(client, "the client given")
        return
    if scheduler:
        addr = check_address(scheduler)
        t0 = time.perf_counter()
        with _quiet_dask():
            try:
                _probe(addr)
                cl = Client(addr, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
            except Exception as exc:
                raise SchedulerError(
                    f"--scheduler {addr}: no Dask scheduler answers there "
                    f"({time.perf_counter() - t0:.0f} s: "
                    f"{one_line(str(exc) or type(exc).__name__, 160)})"
                ) from None
        try:
            yield _describe(cl, addr)
        finally:
            with _quiet_dask():
                cl.close()
        return
    slots = workers or default_slots()
    if n_runs:
        slots = min(slots, n_runs) if workers is None else slots
    budget = memory_mb if memory_mb is not None else default_memory_mb()
    with _quiet_dask():
        # the worker lives in this process (its threads only wait for the runs'
        # own processes): no interpreter to start, nothing of the caller's
        # __main__ re-imported, and nothing left behind when this process ends
        cluster = LocalCluster(
            n_workers=1,
            threads_per_worker=slots,
            processes=False,
            memory_limit=0,
            resources={RESOURCE: budget * 2**20},
            # a free port: with None the scheduler's HTTP server still takes
            # 8787, and a second sweep on the machine then warns and leaks a socket
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
            local_directory=str(_tmp_root()),
        )
        cl = Client(cluster, set_as_default=False)
    try:
        yield Where(
            cl, budget, f"a local cluster of {slots} run slot{'s' if slots > 1 else ''}, {budget / 1024:.1f} GB", slots
        )
    finally:
        with _quiet_dask():
            try:
                cl.close()
            finally:
                cluster.close()
                close_launchers()
                _stopping.clear()


def _probe(addr: str) -> None:
    """Connect and shake hands with whatever listens at ``addr`` (a Client
    that fails half-way would hang on closing)."""
    import asyncio

    from distributed.comm import connect

    async def go() -> None:
        comm = await connect(addr, timeout=CONNECT_TIMEOUT_S)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(go(), CONNECT_TIMEOUT_S + 1))
    except MemoryError:
        raise OSError("something answers, but not in the Dask protocol") from None
    except TimeoutError:
        raise OSError(f"no answer within {CONNECT_TIMEOUT_S:.0f} s") from None


def _describe(client: Client, name: str) -> Where:
    info = client.scheduler_info(n_workers=-1) if _accepts_n_workers(client) else client.scheduler_info()
    ws = info.get("workers", {})
    threads = sum(w.get("nthreads", 0) for w in ws.values())
    mem = [w.get("resources", {}).get(RESOURCE) for w in ws.values()]
    budget = max((m for m in mem if m), default=None)
    text = f"{name}: {len(ws)} worker{'s' if len(ws) != 1 else ''}, {threads} thread{'s' if threads != 1 else ''}" + (
        f", {RESOURCE} {budget / 2**30:.1f} GB per worker at most"
        if budget
        else f", no {RESOURCE} resource (runs placed by free threads only; start workers with "
        f"--resources {RESOURCE}=<bytes>)"
    )
    return Where(client, budget / 2**20 if budget else None, text, threads)


def _accepts_n_workers(client: Client) -> bool:
    import inspect

    try:
        return "n_workers" in inspect.signature(client.scheduler_info).parameters
    except (TypeError, ValueError):  # pragma: no cover
        return False


# ---------------------------------------------------------------- runs


def plan_estimates(jobs: Sequence[LinkJob], cache_dir: Path) -> tuple[list[str], list[bool], list[int], list[float]]:
    """Cache keys, whether each run's FEA is cached, estimated nodes and memory (MB)."""
    keys = [cache_key(j, resolve_route(j)) for j in jobs]
    cached = [(cache_dir / f"{k}.npz").is_file() for k in keys]
    nodes = [estimate_nodes(j) for j in jobs]
    mem = [CACHED_MB if c else estimate_memory_mb(n) for c, n in zip(cached, nodes)]
    return keys, cached, nodes, mem


def run_jobs(
    jobs: list,
    labels: list[str],
    cache_dir: Path | str,
    *,
    client: Client | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    memory_mb: float | None = None,
    progress: bool = True,
    title: str = "sweep",
    stream: TextIO | None = None,
) -> list[dict]:
    """Run every LinkJob as a task; results in job order (dicts of table
    fields, see :mod:`stiffkit.sweep.table`, plus ``memory_est_mb``,
    ``start_s``, ``end_s``, ``task_s``)."""
    cache = Path(cache_dir).expanduser().resolve()
    cache.mkdir(parents=True, exist_ok=True)
    _stopping.clear()
    remove_stale_temporaries(cache)
    keys, cached, _nodes, mem = plan_estimates(jobs, cache)
    bar = Progress(len(jobs), progress, stream)
    with open_cluster(client, scheduler, workers, memory_mb, len(jobs)) as where:
        cl = where.client
        bar.say(f"{title}: {len(jobs)} runs ({sum(cached)} in the cache) on {where.text}; cache {cache}")
        if where.budget_mb:
            for lab, m in zip(labels, mem):
                if m > where.budget_mb:
                    bar.say(
                        f"  {lab}: estimated {m / 1024:.1f} GB, more than the {where.budget_mb / 1024:.1f} GB "
                        "budget: it runs alone"
                    )
        send_cad = bool(scheduler) or client is not None
        token = uuid.uuid4().hex[:8]
        t0 = time.time()
        futs, first, needs = [], {}, []
        for i, job in enumerate(jobs):
            spec = {"job": job, "cache_dir": str(cache)}
            step = job.geometry.get("step")
            if send_cad and step and os.path.getsize(step) < 64 * 2**20:
                spec["cad"] = Path(step).read_bytes()
            after = first.get(keys[i])
            need = CACHED_MB if after is not None else mem[i]
            needs.append(need)
            res = {RESOURCE: min(need, where.budget_mb) * 2**20} if where.budget_mb else None
            f = cl.submit(
                run_task,
                spec,
                *([after] if after is not None else []),
                resources=res,
                key=f"stiffkit-run-{i + 1}-{keys[i]}-{token}",
                pure=False,
                retries=0,
            )
            first.setdefault(keys[i], f)
            futs.append(f)
        index = {f.key: i for i, f in enumerate(futs)}
        results: list[dict | None] = [None] * len(jobs)
        from distributed import as_completed

        try:
            for f in as_completed(futs, loop=cl.loop):
                i = index[f.key]
                if f.status == "finished":
                    r = f.result()
                else:  # a lost worker, a cancelled task
                    try:
                        exc = f.exception()
                    except (KeyboardInterrupt, SystemExit):
                        raise
                    except BaseException as e:  # cancelled: there is no exception to fetch
                        exc = e
                    r = failed_fields(f"the task failed on its worker ({type(exc).__name__}: {exc})")
                for text in dict.fromkeys(r.pop("warnings", None) or []):  # the run's warnings, once each
                    warnings.warn(StiffkitWarning(f"{labels[i]}: {text}"), stacklevel=2)
                r["memory_est_mb"] = needs[i]
                if "t_start" in r:
                    r["start_s"], r["end_s"] = r.pop("t_start") - t0, r.pop("t_end") - t0
                    r["task_s"] = r["end_s"] - r["start_s"]
                results[i] = r
                bar.update(labels[i], r)
        except BaseException:
            stop_local_runs()  # runs of workers in this process
            with _quiet_dask():
                cl.cancel(futs, force=True)
            raise
        finally:
            bar.close()
    return results


__all__ = [
    "run_jobs",
    "run_task",
    "open_cluster",
    "estimate_nodes",
    "estimate_memory_mb",
    "check_address",
    "SchedulerError",
    "Progress",
    "RESOURCE",
    "default_slots",
    "default_memory_mb",
]
