"""Reading a URDF, checking its tree and building its model are linear in
the number of links (issue 17.7: a step that was quadratic made 70,000
links take more than 8 minutes). CPU time, the best of a few runs, for
16 times more links: at most 3 times the linear ratio (a quadratic step
gives 16 times more); the absolute figures belong to bench/bench_urdf.py."""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import tree_model_from_tables

_BENCH = Path(__file__).resolve().parents[1] / "bench" / "bench_urdf.py"


def _chain_urdf(n: int) -> str:
    """The bench's chain of n links (one revolute joint, n - 1 fixed joints, a mass on each link)."""
    spec = importlib.util.spec_from_file_location("bench_urdf", _BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.chain_urdf(n)


def _best_cpu(path: Path, n: int, runs: int) -> float:
    best = float("inf")
    for _ in range(runs):
        c0 = time.process_time()
        tree = load_tree(path)
        model = tree_model_from_tables(tree, [{"kind": "tracker"}, {"kind": "marker", "target": f"l{n - 1}"}])
        best = min(best, time.process_time() - c0)
    assert len(tree.links) == n + 1 and len(tree.joints) == n and tree.actuated == ["j0"]
    assert len(tree.inertials) == n - 1 and abs(tree.total_mass - 0.001 * (n - 1)) < 1e-9 * n
    assert model.arrays["vparent"].size == n  # one virtual joint per URDF joint (frames only)
    return best


def test_reading_and_building_are_linear_in_the_links(tmp_path):
    small, large = 1_000, 16_000
    times = {}
    for n, runs in ((small, 5), (large, 3)):
        p = tmp_path / f"chain{n}.urdf"
        p.write_text(_chain_urdf(n))
        times[n] = _best_cpu(p, n, runs)
    ratio = times[large] / times[small]
    print(f"CPU s {times}: ratio {ratio:.1f}")
    assert ratio < 3 * large / small, f"CPU {times}: ratio {ratio:.1f} for {large // small} times the links"
