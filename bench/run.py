"""Run every benchmark script bench/bench_*.py in turn (make bench).

Each script prints its own table; figures go into the README's results
section with the command that reproduces them (`make bench` or
`python bench/bench_<name>.py`).
"""

from __future__ import annotations

import runpy
import sys
import time
from pathlib import Path

here = Path(__file__).resolve().parent
only = sys.argv[1:]
for script in sorted(here.glob("bench_*.py")):
    if only and not any(o in script.stem for o in only):
        continue
    print(f"== {script.name}", flush=True)
    t0 = time.perf_counter()
    runpy.run_path(str(script), run_name="__main__")
    print(f"== {script.name}: {time.perf_counter() - t0:.1f} s\n", flush=True)
