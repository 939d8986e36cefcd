"""Atomic file writes shared by every stage.

A file stiffkit writes is either the old one or the complete new one, never
a half-written one (an interrupted run, a full disk, two runs writing the
same cache entry): the content goes to a unique temporary in the same
folder, which ``os.replace`` then moves over the target in one step. The
temporary is removed when the write fails. The target's folder is created
when missing.

A target that is not a regular file is never replaced: a character device
(``/dev/null``, ``/dev/stdout``, ``/dev/full``) or a FIFO is written in
place (the complete content, once it is ready; a FIFO that no process reads
is an error, and so is the device's own, e.g. "no space left" for
``/dev/full``); a block device, a socket or a folder is refused. A symbolic
link is followed: the file it points to is replaced, the link stays.
``check_output`` finds the refusals, and a folder that cannot be written,
before any work is done.
"""

from __future__ import annotations

import errno
import fcntl
import json
import math
import numbers
import os
import shutil
import stat
import tempfile
import tomllib
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import IO, TYPE_CHECKING

import numpy as np

from ..errors import InputError, StiffkitError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "check_output",
    "check_folder",
    "check_plots_folder",
    "model_inputs",
    "link_inputs",
    "atomic_path",
    "atomic_open",
    "atomic_write_bytes",
    "atomic_write_text",
    "write_json",
    "save_figure",
    "FIGURE_SUFFIXES",
    "pyplot",
]


def _temporary(path: Path) -> Path:
    """A name beside ``path`` that no other writer uses; it keeps the
    target's suffix so that writers choosing a format by suffix agree."""
    return path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:12]}.tmp{path.suffix}")


def _named(exc: OSError, path: Path, tmp: Path | None) -> OSError:
    """The error of a write with the user's path in it, not the temporary's."""
    if exc.filename is None or (tmp is not None and str(exc.filename) == str(tmp)) or exc.filename2 is not None:
        new = type(exc)(exc.errno, exc.strerror or str(exc), str(path)) if exc.errno else OSError(str(exc))
        if not exc.errno:
            new.filename = str(path)
        return new
    return exc


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    return "not a regular file"


def _in_place(mode: int) -> bool:
    """Targets written in place rather than replaced."""
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)


def _stat(path: Path) -> os.stat_result | None:
    """The target's status (symbolic links followed), None when missing."""
    try:
        return os.stat(path)
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        return None


def check_folder(folder: Path | str, what: str, label: Path | str | None = None) -> Path:
    """A folder a command will write into, checked before the work: the
    folder, or its nearest existing ancestor when it is to be created, must
    be a folder this process can create files in (a file is created there
    and removed: permissions, a read-only file system). InputError naming
    ``label`` (the user's path; default the folder) otherwise."""
    folder = Path(folder)
    label = folder if label is None else label
    probe = folder
    while True:
        st = _stat(probe)
        if st is not None or probe == probe.parent:
            break
        probe = probe.parent
    if st is None:
        raise InputError(f"{what} {label}: no folder to write it in")
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{what} {label}: {probe} is a file, not a folder; it cannot hold the output")
    try:
        fd, name = tempfile.mkstemp(prefix=".stiffkit-probe-", dir=probe)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        if exc.errno in (errno.EACCES, errno.EPERM):
            reason = "permission denied"
        elif exc.errno == errno.EROFS:
            reason = "read-only file system"
        raise InputError(f"{what} {label}: cannot write in the folder {probe} ({reason})") from None
    os.close(fd)
    os.unlink(name)
    return folder


def check_output(path: Path | str, what: str) -> Path:
    """The target of an output, checked before the work (section header):
    InputError naming ``what`` and ``path`` for a folder, a block device or
    a socket, or a folder where the file cannot be created. A character
    device or a FIFO passes (written in place)."""
    path = Path(path)
    st = _stat(path)
    if st is not None and not stat.S_ISREG(st.st_mode):
        if _in_place(st.st_mode):
            return path
        raise InputError(
            f"{what} {path}: is {_kind(st.st_mode)}; stiffkit writes a regular file there (or a character "
            f"device or FIFO, in place) and never replaces anything else"
        )
    target = Path(os.path.realpath(path))
    check_folder(target.parent, what, path)
    return path


def check_plots_folder(folder: Path | str | None, what: str) -> Path | None:
    """A folder of figures (``--plots DIR``), checked before the work: not a
    file, and a folder files can be created in (it is created when missing)."""
    if not folder:
        return None
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{what} {folder}: a file, not a folder")
    return check_folder(folder, what)


def _referenced(path: Path | str | None, table: str, keys: tuple[str, ...]) -> list[Path]:
    """``path`` and the files its TOML names in [table] keys (relative to
    its folder). A file that cannot be read yields only itself: the command
    reports its error when it reads it."""
    if not path:
        return []
    path = Path(path)
    out = [path]
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, ValueError):
        return out
    sec = doc.get(table)
    if not isinstance(sec, dict):
        return out
    for k in keys:
        v = sec.get(k)
        if isinstance(v, str) and v.strip():
            f = Path(v)
            out.append(f if f.is_absolute() else path.parent / f)
    return out


def model_inputs(path: Path | str | None) -> list[Path]:
    """A model TOML and the files it reads ([robot] urdf, nominal_urdf): the
    inputs no output of a command may overwrite."""
    return _referenced(path, "robot", ("urdf", "nominal_urdf"))


def link_inputs(path: Path | str | None) -> list[Path]:
    """A LINK.toml and its CAD file ([geometry] step)."""
    return _referenced(path, "geometry", ("step",))


def _write_in_place(src: Path, path: Path) -> None:
    """The content of ``src`` into the character device or FIFO ``path``
    (opened without blocking: a FIFO nobody reads is an error)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise OSError(errno.ENXIO, "a FIFO that no process reads; start its reader first", str(path)) from None
        raise
    try:
        flags = fcntl.fcntl(fd, fcntl.F_GETFL)
        fcntl.fcntl(fd, fcntl.F_SETFL, flags & ~os.O_NONBLOCK)
        with open(src, "rb") as fh:
            while chunk := fh.read(1 << 20):
                view = memoryview(chunk)
                while view:
                    n = os.write(fd, view)
                    view = view[n:]
    finally:
        os.close(fd)


@contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """Yield the path of a fresh temporary beside ``path``; when the block
    ends without an error the temporary replaces ``path``, otherwise it is
    removed. For writers that want a file name (meshio, numpy). A file
    error names ``path``, never the temporary. A character device or FIFO
    is written in place, other non-regular targets are refused (module
    docstring)."""
    path = Path(path)
    tmp = tmpdir = None
    st = _stat(path)
    if st is not None and not stat.S_ISREG(st.st_mode) and not _in_place(st.st_mode):
        check_output(path, "output")
    in_place = st is not None and _in_place(st.st_mode)
    # a symbolic link stays; the file it points to is replaced
    target = Path(os.path.realpath(path)) if path.is_symlink() and not in_place else path
    try:
        if in_place:
            tmpdir = Path(tempfile.mkdtemp(prefix="stiffkit-out-"))
            tmp = tmpdir / f"out.tmp{path.suffix}"
        else:
            target.parent.mkdir(parents=True, exist_ok=True)
            tmp = _temporary(target)
        yield tmp
        if in_place:
            _write_in_place(tmp, path)
        else:
            os.replace(tmp, target)
    except OSError as exc:
        raise _named(exc, path, tmp) from None
    finally:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        if tmpdir is not None:
            shutil.rmtree(tmpdir, ignore_errors=True)


@contextmanager
def atomic_open(path: Path | str, mode: str = "w", **kwargs: object) -> Iterator[IO]:
    """``open`` for writing, atomically: the handle writes a temporary that
    replaces ``path`` when the block ends without an error."""
    if not any(m in mode for m in "wx"):
        raise ValueError(f"atomic_open writes a new file; mode {mode!r} has no 'w'")
    with atomic_path(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with open(fd, mode.replace("x", "w"), **kwargs) as fh:
            yield fh


def atomic_write_bytes(path: Path | str, data: bytes) -> Path:
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(path: Path | str, text: str) -> Path:
    with atomic_open(path, "w") as fh:
        fh.write(text)
    return Path(path)


def write_json(path: Path | str, data: object, **kwargs: object) -> Path:
    """``data`` as indented JSON (``json.dumps`` keywords pass through).
    Numpy scalars and arrays become plain numbers and lists; a NaN or Inf
    anywhere is refused (StiffkitError naming the file and the key): JSON
    has no such numbers, and a writer maps an undefined value to null."""
    kwargs.pop("allow_nan", None)
    text = json.dumps(json_ready(data, str(path)), indent=1, allow_nan=False, **kwargs)
    return atomic_write_text(path, text)


#: figure formats matplotlib's Agg backend writes
FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff", ".webp", ".pgf")


def save_figure(fig: Figure, path: Path | str, **kwargs: object) -> Path:
    """A matplotlib figure saved atomically; the format is the suffix of
    ``path`` (PNG when it has none), as ``Figure.savefig`` would choose."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix and suffix not in FIGURE_SUFFIXES and "format" not in kwargs:
        raise InputError(f"{path}: cannot write a figure as {suffix!r}; use one of {', '.join(FIGURE_SUFFIXES)}")
    kwargs.setdefault("format", suffix[1:] or "png")
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, **kwargs)
    return path


def pyplot() -> ModuleType:
    """matplotlib.pyplot on the file-only Agg backend, imported on first use
    (matplotlib is heavy and only the writers of figures need it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _key(path: list) -> str:
    out = ""
    for k in path:
        out += f"[{k}]" if isinstance(k, int) else f"[{k!r}]"
    return out


def json_ready(data: object, where: str = "JSON") -> object:
    """``data`` with numpy scalars and arrays turned into plain Python, or
    StiffkitError naming the first NaN/Inf (JSON has no such numbers; a
    writer maps an undefined value to null itself)."""

    def walk(v: object, path: list[str | int]) -> object:
        if isinstance(v, dict):
            return {str(k): walk(x, path + [k]) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [walk(x, path + [i]) for i, x in enumerate(v)]
        if isinstance(v, np.ndarray):
            return walk(v.tolist(), path)
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        if isinstance(v, numbers.Integral):
            return int(v)
        if isinstance(v, numbers.Real):
            f = float(v)
            if not math.isfinite(f):
                raise StiffkitError(
                    f"{where}: the value at {_key(path) or 'top level'} is {f}, which JSON cannot hold "
                    "(a result overflowed or is undefined: check the inputs' units and magnitudes)"
                )
            return f
        if isinstance(v, Path):
            return str(v)
        return v

    return walk(data, [])
