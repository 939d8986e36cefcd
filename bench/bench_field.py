"""Field fits per second: the Fortran core (LIN, exact, SVD) against a plain
numpy least-squares reference in the same run (goal: >= 10x numpy for LIN
at n = 1331).

    python bench/bench_field.py        (or: make bench BENCH=field)
"""

from __future__ import annotations

import time

import numpy as np

import stiffkit as sk
from stiffkit.field.synthetic import cubic_grid, elementary_rotation, rigid_displacements


def numpy_lin(points, disp, ref):
    """Reference: eq. 13 stacked for all nodes, solved by numpy.linalg.lstsq."""
    q = points - ref
    n = q.shape[0]
    A = np.zeros((3 * n, 6))
    A[:, :3] = np.tile(np.eye(3), (n, 1))
    # phi x q = -[q]x phi
    A[0::3, 4], A[0::3, 5] = q[:, 2], -q[:, 1]
    A[1::3, 3], A[1::3, 5] = -q[:, 2], q[:, 0]
    A[2::3, 3], A[2::3, 4] = q[:, 1], -q[:, 0]
    x, *_ = np.linalg.lstsq(A, disp.reshape(-1), rcond=None)
    return x


def rate(fn, min_time=0.4, repeats=5):
    """Calls per second: the best of `repeats` timed runs (the least
    disturbed by the other load on a shared machine), for both sides."""
    fn()
    best = 0.0
    for _ in range(repeats):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            dt = time.perf_counter() - t0
            if dt >= min_time:
                break
        best = max(best, n / dt)
    return best


def main():
    rng = np.random.default_rng(0)
    print(f"{'nodes':>8s} {'method':>14s} {'fits/s':>12s} {'vs numpy':>9s}")
    for n_side, _label in ((11, 1331), (47, 47**3)):
        pts = cubic_grid(10.0, 10.0 / (n_side - 1))
        d = rigid_displacements(pts, np.zeros(3), [0.1, 0.2, 0.3], elementary_rotation(np.radians(0.1)))
        d += 5e-5 * rng.standard_normal(d.shape)
        ref = np.zeros(3)
        base = rate(lambda: numpy_lin(pts, d, ref))
        x = numpy_lin(pts, d, ref)
        f = sk.fit_field(pts, d, ref, method="lin")
        assert np.allclose(x, f.deflection, rtol=1e-9, atol=1e-14), "numpy and core disagree"
        print(f"{pts.shape[0]:8d} {'numpy lstsq':>14s} {base:12.1f} {1.0:9.1f}")
        for m in ("lin", "exact", "svd+-"):
            r = rate(lambda: sk.fit_field(pts, d, ref, method=m))
            print(f"{pts.shape[0]:8d} {'core ' + m:>14s} {r:12.1f} {r / base:9.1f}")
        # batch: 100 fields sharing the nodes in one core call
        if pts.shape[0] < 5000:
            D = np.repeat(d[None], 100, axis=0)
            r = 100 * rate(lambda: sk.fit_fields(pts, D, ref, method="lin"))
            print(f"{pts.shape[0]:8d} {'core lin x100':>14s} {r:12.1f} {r / base:9.1f}")


if __name__ == "__main__":
    main()
