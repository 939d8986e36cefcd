"""Write tests/data/deflection_reference.json.gz: the numbers of every case
of tests/_deflection_cases.py (predictions, Jacobians, fitted parameters,
the M1-M5 reduction, the KR-270 example, the demo's error fall), computed by
the code of the day it is run. tests/test_deflection_reference.py checks
today's code against it (1e-9 relative).

    .venv/bin/python tests/data/make_deflection_reference.py
"""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import _deflection_cases as C  # noqa: E402


def main() -> None:
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    doc = {"commit": commit, "cases": {}}
    for name in C.CASES:
        print("case", name, flush=True)
        doc["cases"][name] = {k: C.encode(v) for k, v in C.compute(name).items()}
    text = json.dumps(doc, separators=(",", ":"))
    with gzip.open(HERE / "deflection_reference.json.gz", "wt", encoding="utf-8", compresslevel=9) as f:
        f.write(text)


if __name__ == "__main__":
    main()
