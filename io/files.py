"""Atomic file writes shared by every stage.

A file stiffkit writes is either the old one or the complete new one, never
a half-written one (an interrupted run, a full disk, two runs writing the
same cache entry): the content goes to a unique temporary in the same
folder, which ``os.replace`` then moves over the target in one step. The
temporary is removed when the write fails. The target's folder is created
when missing.
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import IO, TYPE_CHECKING

from ..errors import InputError
from .validate import json_ready

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
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


@contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """Yield the path of a fresh temporary beside ``path``; when the block
    ends without an error the temporary replaces ``path``, otherwise it is
    removed. For writers that want a file name (meshio, numpy). A file
    error names ``path``, never the temporary."""
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = _temporary(path)
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise _named(exc, path, tmp) from None
    except BaseException:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise


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
