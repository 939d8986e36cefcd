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

__all__ = [
    "atomic_path",
    "atomic_open",
    "atomic_write_bytes",
    "atomic_write_text",
    "write_json",
    "save_figure",
    "pyplot",
]


def _temporary(path: Path) -> Path:
    """A name beside ``path`` that no other writer uses; it keeps the
    target's suffix so that writers choosing a format by suffix agree."""
    return path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:12]}.tmp{path.suffix}")


@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield the path of a fresh temporary beside ``path``; when the block
    ends without an error the temporary replaces ``path``, otherwise it is
    removed. For writers that want a file name (meshio, numpy)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temporary(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_open(path, mode: str = "w", **kwargs):
    """``open`` for writing, atomically: the handle writes a temporary that
    replaces ``path`` when the block ends without an error."""
    if not any(m in mode for m in "wx"):
        raise ValueError(f"atomic_open writes a new file; mode {mode!r} has no 'w'")
    with atomic_path(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with open(fd, mode.replace("x", "w"), **kwargs) as fh:
            yield fh


def atomic_write_bytes(path, data: bytes) -> Path:
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(path, text: str) -> Path:
    with atomic_open(path, "w") as fh:
        fh.write(text)
    return Path(path)


def write_json(path, data, **kwargs) -> Path:
    """``data`` as indented JSON (``json.dumps`` keywords pass through)."""
    return atomic_write_text(path, json.dumps(data, indent=1, **kwargs))


def save_figure(fig, path, **kwargs) -> Path:
    """A matplotlib figure saved atomically; the format is the suffix of
    ``path`` (PNG when it has none), as ``Figure.savefig`` would choose."""
    path = Path(path)
    kwargs.setdefault("format", path.suffix[1:].lower() or "png")
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, **kwargs)
    return path


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend, imported on first use
    (matplotlib is heavy and only the writers of figures need it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
