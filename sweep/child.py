"""Every run of a sweep in a fresh process of its own.

A run is meshed (gmsh, which keeps global state), solved (ccx, CHOLMOD) and
fitted in a process that exists only for it: its peak memory is its own, a
crash takes only it down, and what it allocated goes back to the system.
Starting Python and importing numpy, gmsh and stiffkit costs ~0.5 s, so a
dask worker thread keeps one *launcher* (``python -m stiffkit.sweep.child
serve``) that has imported them once and forks a child per run (~10 ms).

Launcher protocol (one run at a time): the worker writes ``SPEC\\tRESULT\\n``
on the launcher's stdin; the launcher forks, the child runs the pickled spec
and writes the JSON result; the launcher answers the child's wait status
``N\\n``. A launcher whose worker thread goes away (Linux parent-death
signal) or whose stdin closes stops its child, and the child stops its ccx.

``python -m stiffkit.sweep.child run SPEC RESULT`` runs one spec without a
launcher (the fallback).
"""

from __future__ import annotations

import json
import os
import pickle
import signal
import sys
import time
import traceback
import warnings
from pathlib import Path
from types import FrameType

_PR_SET_PDEATHSIG = 1


def _parent_death_signal(sig: int = signal.SIGTERM) -> None:
    """Ask Linux to send ``sig`` to this process when its parent exits."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


def _descendants(pid: int) -> list[int]:
    """Process ids below ``pid`` (children first), from /proc."""
    kids: dict[int, list[int]] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:  # pragma: no cover
        return []
    for e in entries:
        if not e.isdigit():
            continue
        try:
            with open(f"/proc/{e}/stat", "rb") as fh:
                stat = fh.read()
            ppid = int(stat[stat.rindex(b")") + 2 :].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        kids.setdefault(ppid, []).append(int(e))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        for c in kids.get(p, []):
            out.append(c)
            todo.append(c)
    return out


def _kill_descendants() -> None:
    for pid in _descendants(os.getpid()):
        try:
            os.killpg(pid, signal.SIGKILL) if os.getpgid(pid) == pid else os.kill(pid, signal.SIGKILL)
        except OSError:
            pass


def _write_json(path: str, obj: dict) -> None:
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w") as fh:
        json.dump(obj, fh)
    os.replace(tmp, path)


def run_spec(spec_path: str, result_path: str) -> int:
    """Run one pickled spec; write its result (a dict of table fields) as JSON."""
    from ..errors import StiffkitError, StiffkitWarning
    from ..fea.job import run_link
    from .table import failed_fields, run_fields

    where = {"cache": None}

    def stop(signum: int, _frame: FrameType | None) -> None:
        _kill_descendants()  # ccx runs in a session of its own
        if where["cache"]:  # os._exit skips the atomic writers' cleanup: no half-written entry stays
            for tmp in Path(where["cache"]).glob(f".*.{os.getpid()}-*.tmp*"):
                tmp.unlink(missing_ok=True)
        _write_json(result_path, failed_fields(f"interrupted (signal {signal.Signals(signum).name})"))
        os._exit(128 + signum)

    for s in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        signal.signal(s, stop)
    t0 = time.perf_counter()
    said: list[str] = []
    try:
        with open(spec_path, "rb") as fh:
            spec = pickle.load(fh)
        where["cache"] = spec["cache_dir"]
        # the run's warnings (an unreadable cache entry solved again) travel
        # with its result: the sweep gives them on the user's terminal
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", StiffkitWarning)
            res = run_link(spec["job"], cache_dir=spec["cache_dir"], workdir=spec.get("workdir"))
        said = [str(w.message) for w in caught if issubclass(w.category, StiffkitWarning)]
        out = run_fields(res)
    except StiffkitError as exc:
        out = failed_fields(str(exc))
    except MemoryError:
        out = failed_fields("out of memory")
    except Exception as exc:  # a bug: the reason says where
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {os.path.basename(tb[-1].filename)}:{tb[-1].lineno}" if tb else ""
        out = failed_fields(f"{type(exc).__name__}: {exc}{where}")
    out["child_s"] = time.perf_counter() - t0
    if said:
        out["warnings"] = said
    _write_json(result_path, out)
    return 0


def serve() -> None:
    """The launcher loop (see the module docstring)."""
    # what every run needs, imported once here and shared by the forks
    import gmsh  # noqa: F401
    import numpy  # noqa: F401

    from ..fea import job as _job  # noqa: F401
    from . import table as _table  # noqa: F401

    _parent_death_signal(signal.SIGTERM)
    current = {"pid": 0}

    def stop(signum: int, _frame: FrameType | None) -> None:
        if current["pid"]:
            try:
                os.kill(current["pid"], signal.SIGTERM)
                os.waitpid(current["pid"], 0)
            except OSError:
                pass
        os._exit(0)

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGHUP, stop)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the worker decides; the run's child stops itself
    out = sys.stdout
    for line in sys.stdin:
        line = line.rstrip("\n")
        if not line:
            continue
        spec, result = line.split("\t")
        pid = os.fork()
        if pid == 0:
            _parent_death_signal(signal.SIGTERM)
            os.dup2(2, 1)  # stdout is the launcher's answer channel
            code = 1
            try:
                signal.signal(signal.SIGINT, signal.default_int_handler)
                code = run_spec(spec, result)
            finally:
                os._exit(code)
        current["pid"] = pid
        _, status = os.waitpid(pid, 0)
        current["pid"] = 0
        out.write(f"{status}\n")
        out.flush()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["serve"]:
        serve()
        return 0
    if argv[:1] == ["run"] and len(argv) == 3:
        _parent_death_signal(signal.SIGTERM)
        return run_spec(argv[1], argv[2])
    print("usage: python -m stiffkit.sweep.child serve | run SPEC RESULT", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
