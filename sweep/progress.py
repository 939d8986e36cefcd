"""The progress of a sweep's runs on the terminal (sweep/runner.py)."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """One bar over the runs with finished / failed counts: tqdm on a
    terminal, else one line per finished run (logs)."""

    def __init__(self, total: int, enabled: bool = True, stream: TextIO | None = None) -> None:
        self.total, self.enabled = total, enabled
        self.out = stream or sys.stderr
        self.done = self.ok = self.failed = self.cached = 0
        self.t0 = time.perf_counter()
        self.bar = None
        if enabled and hasattr(self.out, "isatty") and self.out.isatty():
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit="run", file=self.out, dynamic_ncols=True)
            except ImportError:
                self.bar = None

    def say(self, text: str) -> None:
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.write(text, file=self.out)
        else:
            self.out.write(text + "\n")
            self.out.flush()

    def update(self, label: str, res: dict) -> None:
        self.done += 1
        if res.get("status") == "ok":
            self.ok += 1
            self.cached += bool(res.get("cached"))
            what = (
                f"{res['nodes']} nodes, {res['wall_s']:.1f} s, {res['memory_mb']:.0f} MB"
                f"{' (cache)' if res.get('cached') else ''}"
            )
        else:
            self.failed += 1
            what = f"FAILED: {res.get('reason', '')}"
        if not self.enabled:
            return
        counts = f"ok {self.ok}, failed {self.failed}"
        if self.bar is not None:
            self.bar.set_postfix_str(counts, refresh=False)
            self.bar.update(1)
            if res.get("status") != "ok":
                self.bar.write(f"{label}: {what}", file=self.out)
            return
        n = self.total
        width = min(n, 40)
        filled = round(width * self.done / n)
        self.out.write(
            f"[{'#' * filled}{'.' * (width - filled)}] {self.done}/{n} {counts} | {label}: {what}"
            f"   elapsed {time.perf_counter() - self.t0:.0f} s\n"
        )
        self.out.flush()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
