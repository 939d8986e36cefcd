"""CalculiX decks, runs and .dat results.

Decks are written in SI units. Traps handled here (docs/toolchain.md):
numbers fit ccx's 20-character fields; *COUPLING + *DISTRIBUTING refers to
an element-face surface; every step's *CLOAD has OP=NEW; the job name is
given without ``.inp``; exit status 201 is an input error whose text is in
ccx's output; a malformed deck can make ccx loop, so every run has a timeout.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import signal
import subprocess
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ..errors import StiffkitError
from ..io.files import atomic_open

if TYPE_CHECKING:
    from ..meshing import Mesh

LOAD_LABELS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


class CcxError(StiffkitError):
    """CalculiX failed, timed out, or wrote results that cannot be read."""


def ccx_executable() -> str:
    exe = shutil.which(os.environ.get("STIFFKIT_CCX", "ccx"))
    if exe is None:
        raise CcxError(
            "the CalculiX solver `ccx` is not on PATH (Debian package calculix-ccx; `make install` installs it)"
        )
    return exe


# ---------------------------------------------------------------- decks


def _write_mesh(fh: IO[str], nodes: np.ndarray, elements: np.ndarray, ccx_type: str) -> None:
    fh.write("*NODE, NSET=NALL\n")
    ids = np.arange(1, nodes.shape[0] + 1)
    np.savetxt(fh, np.column_stack([ids, nodes]), fmt=["%d", "%.12e", "%.12e", "%.12e"], delimiter=", ")
    fh.write(f"*ELEMENT, TYPE={ccx_type}, ELSET=EALL\n")
    eids = np.arange(1, elements.shape[0] + 1)
    rows = np.column_stack([eids, elements])
    if rows.shape[1] <= 16:
        np.savetxt(fh, rows, fmt="%d", delimiter=", ")
        return
    # ccx reads at most 16 entries a line: C3D20R goes on two (the first ends with a comma)
    head, tail = rows[:, :16], rows[:, 16:]
    fmt_h = ", ".join(["%d"] * 16) + ",\n"
    fmt_t = ", ".join(["%d"] * tail.shape[1]) + "\n"
    fh.write("".join(fmt_h % tuple(h) + fmt_t % tuple(t) for h, t in zip(head.tolist(), tail.tolist())))


def _write_set(fh: IO[str], kind: str, name: str, items: npt.ArrayLike) -> None:
    fh.write(f"*{kind}, {kind}={name}\n")
    items = np.asarray(items, dtype=np.int64)
    for k in range(0, items.size, 12):
        fh.write(", ".join(str(int(v)) for v in items[k : k + 12]) + "\n")


def _write_boundary(fh: IO[str], held: Sequence[tuple[int, Sequence[int]]] | None) -> None:
    """*BOUNDARY: the NFIX set in x, y, z, or (``held``) only the listed
    (node, dofs) pairs, e.g. the statically determinate hold of a
    distributing support."""
    fh.write("*BOUNDARY\n")
    if held is None:
        fh.write("NFIX, 1, 3\n")
        return
    for node, dofs in held:
        for d in dofs:
            fh.write(f"{int(node)}, {int(d)}, {int(d)}\n")


def _write_material(fh: IO[str], E: float, nu: float, density: float | None) -> None:
    fh.write(f"*MATERIAL, NAME=MAT\n*ELASTIC\n{E:.10e}, {nu:.10g}\n")
    if density is not None:
        fh.write(f"*DENSITY\n{density:.10e}\n")
    fh.write("*SOLID SECTION, ELSET=EALL, MATERIAL=MAT\n")


@dataclass
class StaticDeck:
    """What a six-step deck defines: node numbers of the reference (and,
    for *RIGID BODY, rotation) node, and the load of each step."""

    path: Path
    ref_node: int
    rot_node: int | None
    amplitudes: np.ndarray


def write_static_deck(
    path: Path | str,
    mesh: Mesh,
    E: float,
    nu: float,
    fixed_nodes: npt.ArrayLike,
    load_faces: Iterable[Sequence[int]] | np.ndarray,
    load_nodes: npt.ArrayLike,
    reference_point: Sequence[float] | np.ndarray,
    coupling: str,
    amplitudes: npt.ArrayLike,
    print_all: bool = True,
    held: Sequence[tuple[int, Sequence[int]]] | None = None,
    support_loads: tuple[np.ndarray, np.ndarray] | None = None,
    load_forces: tuple[np.ndarray, np.ndarray] | None = None,
) -> StaticDeck:
    """Six *STATIC steps, one unit-direction wrench each (scaled by
    ``amplitudes``), at a reference node coupled to the load face:
    ``coupling = "distributing"`` (*COUPLING + *DISTRIBUTING on the element
    faces ``load_faces`` [(element, face)]) or ``"rigid"`` (*RIGID BODY on
    ``load_nodes``; moments go on the ROT node). Root nodes clamped in 1-3,
    or (a distributing support) only the ``held`` (node, dofs) pairs, with
    ``support_loads`` = (nodes, g (6, ns, 3)): nodal forces -g[j] of the
    unit wrench j added to step j (the support's distributed reaction).
    ``load_forces`` = (nodes, g): a distributing coupling written as these
    nodal forces instead of *COUPLING (hexahedra: ccx's own weights of
    quadratic quadrilaterals are not the core's; the REF node is then held).
    """
    path = Path(path)
    amps = np.asarray(amplitudes, dtype=float)
    n = mesh.n_nodes
    ref, rot = n + 1, (n + 2 if coupling == "rigid" else None)
    with atomic_open(path) as fh:
        fh.write("** stiffkit: six unit-direction load cases at a reference point\n")
        _write_mesh(fh, mesh.nodes, mesh.elements, mesh.ccx_type)
        p = reference_point
        fh.write(f"*NODE, NSET=NREF\n{ref}, {p[0]:.12e}, {p[1]:.12e}, {p[2]:.12e}\n")
        if rot is not None:
            fh.write(f"{rot}, {p[0]:.12e}, {p[1]:.12e}, {p[2]:.12e}\n")
        if held is None:
            _write_set(fh, "NSET", "NFIX", fixed_nodes)
        _write_set(fh, "NSET", "NLOAD", load_nodes)
        if coupling == "distributing" and load_forces is not None:
            pass  # nodal forces in each step
        elif coupling == "distributing":
            fh.write("*SURFACE, NAME=SLOAD, TYPE=ELEMENT\n")
            for e, s in load_faces:
                fh.write(f"{int(e)}, S{int(s)}\n")
            fh.write(f"*COUPLING, REF NODE={ref}, SURFACE=SLOAD, CONSTRAINT NAME=CLOAD\n*DISTRIBUTING\n1, 6\n")
        else:
            fh.write(f"*RIGID BODY, NSET=NLOAD, REF NODE={ref}, ROT NODE={rot}\n")
        _write_material(fh, E, nu, None)
        _write_boundary(fh, held)
        if coupling == "distributing" and load_forces is not None:
            fh.write(f"{ref}, 1, 3\n")  # the REF node carries nothing
        for j in range(6):
            if j < 3:
                node, dof = ref, j + 1
            else:
                node, dof = (ref, j + 1) if rot is None else (rot, j - 2)
            fh.write(f"** load case {j + 1}: {LOAD_LABELS[j]} = {amps[j]:.6g}\n")
            fh.write("*STEP\n*STATIC\n*CLOAD, OP=NEW\n")
            if coupling == "distributing" and load_forces is not None:
                lnodes, lg = load_forces
                for i, d in zip(*np.nonzero(lg[j])):
                    fh.write(f"{int(lnodes[i])}, {int(d) + 1}, {amps[j] * lg[j, i, d]:.12e}\n")
            else:
                fh.write(f"{node}, {dof}, {amps[j]:.12e}\n")
            if support_loads is not None:
                snodes, g = support_loads
                for i, d in zip(*np.nonzero(g[j])):
                    fh.write(f"{int(snodes[i])}, {int(d) + 1}, {-amps[j] * g[j, i, d]:.12e}\n")
            fh.write("*NODE PRINT, NSET=NALL\nU\n" if print_all else "*NODE PRINT, NSET=NLOAD\nU\n")
            fh.write("*NODE PRINT, NSET=NREF\nU\n")
            fh.write("*END STEP\n")
    return StaticDeck(path=path, ref_node=ref, rot_node=rot, amplitudes=amps)


def write_matrix_deck(
    path: Path | str,
    mesh: Mesh,
    E: float,
    nu: float,
    density: float,
    fixed_nodes: npt.ArrayLike,
    held: Sequence[tuple[int, Sequence[int]]] | None = None,
) -> Path:
    """Deck whose only step writes the assembled stiffness (and mass)
    matrices: *FREQUENCY, SOLVER=MATRIXSTORAGE (needs *DENSITY). The
    ``fixed_nodes`` are held in x, y, z, or only the ``held`` (node, dofs)."""
    path = Path(path)
    with atomic_open(path) as fh:
        fh.write("** stiffkit: assembled stiffness for the CHOLMOD route\n")
        _write_mesh(fh, mesh.nodes, mesh.elements, mesh.ccx_type)
        if held is None:
            _write_set(fh, "NSET", "NFIX", fixed_nodes)
        _write_material(fh, E, nu, density)
        _write_boundary(fh, held)
        fh.write("*STEP\n*FREQUENCY, SOLVER=MATRIXSTORAGE\n1\n*END STEP\n")
    return path


# ---------------------------------------------------------------- runs


def peak_rss_mb(pid: int | str = "self") -> float:
    """High-water resident memory (VmHWM) of a live process, MB; 0 if unknown.
    (getrusage's ru_maxrss of a child includes its parent's memory at fork
    on Linux, so children are sampled here instead.)"""
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return 0.0


@dataclass
class CcxRun:
    seconds: float
    max_rss_mb: float
    log: str


def _error_text(log: str, limit: int = 6) -> str:
    lines = log.splitlines()
    out = []
    for i, ln in enumerate(lines):
        if "*ERROR" in ln.upper():
            block = [ln.strip()] + [x.strip() for x in lines[i + 1 : i + 4] if x.strip()]
            out.append(" ".join(block))
    return " | ".join(out[:limit])


_FACTOR = re.compile(rb"Factoring the system of equations")


def matrix_shim() -> str | None:
    """Path of the LD_PRELOAD library (core/sk_ccxio.c) that makes ccx's
    MATRIXSTORAGE run skip the mass matrix (and, with STIFFKIT_EXACT_K=1 in
    its environment, as :func:`exact_k` asks by default,
    write K as exact binary records); None where it is not built (ccx then
    writes its text files)."""
    try:
        spec = importlib.util.find_spec("stiffkit._core._ccxio")
    except (ImportError, ValueError):
        return None
    return spec.origin if spec is not None and spec.origin and Path(spec.origin).is_file() else None


def exact_k() -> bool:
    """True when the matrix route reads K exactly (the default where the
    shim is built): ccx's K as binary records, not its 14-digit text.
    STIFFKIT_EXACT_K=0 asks for the text."""
    return matrix_shim() is not None and os.environ.get("STIFFKIT_EXACT_K", "1") != "0"


def run_ccx(
    deck: Path,
    timeout: float = 3600.0,
    threads: int = 1,
    progress: Callable[[str], None] | None = None,
    preload: str | None = None,
    env: dict[str, str] | None = None,
) -> CcxRun:
    """Run ``ccx -i job`` in the deck's folder; raise CcxError with ccx's
    own error text on failure (exit 201: input error) or after ``timeout``.
    ``progress(msg)`` is told when ccx starts each *STEP; ``preload``: a
    library for LD_PRELOAD (:func:`matrix_shim`); ``env``: variables set
    for this run only."""
    exe = ccx_executable()
    deck = Path(deck)
    # line-buffered output (C stdio via stdbuf, gfortran units) so that the
    # log shows ccx's progress while it runs
    env = dict(
        os.environ,
        OMP_NUM_THREADS=str(threads),
        CCX_NPROC_STIFFNESS=str(threads),
        CCX_NPROC_EQUATION_SOLVER=str(threads),
        GFORTRAN_UNBUFFERED_PRECONNECTED="y",
        **(env or {}),
    )
    if preload:
        env["LD_PRELOAD"] = " ".join(x for x in (preload, os.environ.get("LD_PRELOAD", "")) if x)
    stdbuf = shutil.which("stdbuf")
    cmd = ([stdbuf, "-oL"] if stdbuf else []) + [exe, "-i", deck.stem]
    logf = deck.with_suffix(".log")
    t0 = time.perf_counter()
    with open(logf, "w") as out:
        proc = subprocess.Popen(
            cmd, cwd=deck.parent, stdout=out, stderr=subprocess.STDOUT, env=env, start_new_session=True
        )
        try:
            rc, rss = _wait(proc, logf, t0, timeout, progress, deck)
        except BaseException:  # Ctrl-C, SIGTERM, a timeout: ccx and its children go too
            _kill_group(proc)
            raise
    log = logf.read_text(errors="replace")
    seconds = time.perf_counter() - t0
    err = _error_text(log)
    if rc != 0 or err:
        what = "input error" if rc == 201 else f"exit status {rc}"
        detail = err or " | ".join(x.strip() for x in log.strip().splitlines()[-4:])
        raise CcxError(f"ccx {what} in {deck}: {detail}")
    return CcxRun(seconds=seconds, max_rss_mb=rss, log=log)


def _kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL ccx's process group (it runs in a session of its own, with
    stdbuf and any helper it starts) and reap it."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL is not ignored
        pass


def _wait(
    proc: subprocess.Popen, logf: Path, t0: float, timeout: float, progress: Callable[[str], None] | None, deck: Path
) -> tuple[int, float]:
    """Wait for ccx, sampling its peak memory and telling ``progress`` of
    each step; CcxError after ``timeout``. Returns (exit status, peak MB)."""
    rss = 0.0
    polls = 0
    seen = 0
    while True:
        pid, status, _usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            rc = os.waitstatus_to_exitcode(status)
            proc.returncode = rc
            return rc, rss
        if polls % 5 == 0:  # sample ccx's peak memory every ~0.1 s
            rss = max(rss, peak_rss_mb(proc.pid))
        if progress is not None and polls % 50 == 0:
            try:
                steps = len(_FACTOR.findall(logf.read_bytes()))
            except OSError:
                steps = 0
            if steps > seen:
                seen = steps
                progress(f"ccx: solving step {steps} ({time.perf_counter() - t0:.0f} s elapsed)")
        polls += 1
        if time.perf_counter() - t0 > timeout:
            raise CcxError(f"ccx on {deck.name} did not finish within {timeout:.0f} s (log: {logf})")
        time.sleep(0.02)


def ccx_version() -> str:
    try:
        out = subprocess.run([ccx_executable(), "-v"], capture_output=True, text=True, timeout=20).stdout
    except (subprocess.TimeoutExpired, OSError):
        return "unknown"
    m = re.search(r"Version\s+([\w.]+)", out)
    return m.group(1) if m else "unknown"


# ---------------------------------------------------------------- .dat

_HEADER = re.compile(
    r"^\s*(?P<what>[a-z][a-z ]*?)\s*\((?P<comp>[^)]*)\)\s*for set\s+(?P<set>\S+)"
    r"\s+and time\s+(?P<time>\S+)",
    re.IGNORECASE,
)
_EXP3 = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d{2,4})$")


def _number(tok: str) -> float:
    """A Fortran number: '1.5E-05', '0.1234567-100' (3-digit exponent,
    E dropped), '1.0D+03'."""
    try:
        v = float(tok)
    except ValueError:
        m = _EXP3.match(tok)
        if m:
            v = float(m.group(1) + "e" + m.group(2))
        else:
            v = float(tok.replace("D", "E").replace("d", "e"))
    return v


@dataclass
class DatBlock:
    what: str  # e.g. "displacements"
    set: str
    time: float
    ids: np.ndarray  # (k,) node numbers
    values: np.ndarray  # (k, ncomp)


def parse_dat(text: str, source: str = ".dat") -> list[DatBlock]:
    """Blocks of a CalculiX .dat file in file order (several steps give
    several blocks). Tolerates blank lines and 3-digit exponents; raises
    CcxError naming the line for anything else it cannot read."""
    blocks: list[DatBlock] = []
    cur = None
    rows: list = []

    def close() -> None:
        if cur is not None:
            ncomp = len(rows[0]) - 1 if rows else 0
            arr = np.array(rows, dtype=float).reshape(-1, ncomp + 1) if rows else np.zeros((0, 1))
            blocks.append(
                DatBlock(what=cur[0], set=cur[1], time=cur[2], ids=arr[:, 0].astype(np.int64), values=arr[:, 1:])
            )

    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        m = _HEADER.match(line)
        if m:
            close()
            try:
                t = _number(m.group("time"))
            except ValueError:
                raise CcxError(f"{source}, line {lineno}: unreadable time {m.group('time')!r}") from None
            cur = (m.group("what").strip().lower(), m.group("set"), t)
            rows = []
            continue
        if cur is None:
            continue  # preamble (e.g. eigenvalue tables we do not use)
        toks = s.split()
        try:
            node = int(toks[0])
            vals = [_number(t) for t in toks[1:]]
        except ValueError:
            if toks[0].isalpha():  # a block we do not parse (e.g. 'total force')
                close()
                cur, rows = None, []
                continue
            raise CcxError(f"{source}, line {lineno}: cannot read {s[:60]!r}") from None
        if not vals or (rows and len(vals) != len(rows[0]) - 1):
            raise CcxError(
                f"{source}, line {lineno}: expected {len(rows[0]) - 1 if rows else 'some'} "
                f"values after the node number, got {len(vals)}"
            )
        if not all(np.isfinite(vals)):
            raise CcxError(f"{source}, line {lineno}: non-finite value in {s[:60]!r}")
        rows.append([node] + vals)
    close()
    return blocks


def displacements_from_dat(path: Path | str, n_nodes: int, deck: StaticDeck) -> tuple[np.ndarray, np.ndarray]:
    """(6, n, 3) displacements of all nodes per load case, and the (6, 6)
    motion of the REF (translations) and ROT (rotations, rigid body) nodes."""
    path = Path(path)
    if not path.is_file():
        raise CcxError(f"{path}: ccx wrote no .dat file")
    blocks = [b for b in parse_dat(path.read_text(errors="replace"), str(path)) if b.what.startswith("displacements")]
    alln = [b for b in blocks if b.set.upper() in ("NALL", "NLOAD")]
    refb = [b for b in blocks if b.set.upper() == "NREF"]
    if len(alln) != 6 or len(refb) != 6:
        raise CcxError(
            f"{path}: expected 6 load cases of displacements, found {len(alln)} "
            f"(field) and {len(refb)} (reference node)"
        )
    U = np.zeros((6, n_nodes, 3))
    ref = np.zeros((6, 6))
    for j, (b, r) in enumerate(zip(alln, refb)):
        ok = (b.ids >= 1) & (b.ids <= n_nodes)
        U[j, b.ids[ok] - 1] = b.values[ok, :3]
        for nid, v in zip(r.ids, r.values):
            if nid == deck.ref_node:
                ref[:3, j] = v[:3]
            elif deck.rot_node is not None and nid == deck.rot_node:
                ref[3:, j] = v[:3]
    return U, ref
