#!/usr/bin/env python3
"""Python reference for the FEM benchmark: factor and solve the exported stiffness with
SciPy's SuperLU (scipy.sparse.linalg.splu, its default COLAMD ordering).

    cargo bench -p pulsetrack-fem --bench seed001 -- --refine 3 --reps 1 --export /tmp/fem
    python3 scripts/fem_superlu.py /tmp/fem [--reps 3]

Prints the median read, factor and solve times; the assembly is not included (the Rust
side's assembly is reported separately).
"""
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse.linalg


def main():
    d = sys.argv[1]
    reps = int(sys.argv[sys.argv.index("--reps") + 1]) if "--reps" in sys.argv else 3
    t0 = time.perf_counter()
    k = scipy.io.mmread(f"{d}/k.mtx").tocsc()
    f = np.loadtxt(f"{d}/f.txt")
    t_read = time.perf_counter() - t0
    factor, solve = [], []
    for _ in range(reps):
        t1 = time.perf_counter()
        lu = scipy.sparse.linalg.splu(k)
        t2 = time.perf_counter()
        u = lu.solve(f)
        t3 = time.perf_counter()
        factor.append(t2 - t1)
        solve.append(t3 - t2)
    res = np.linalg.norm(k @ u - f) / np.linalg.norm(f)
    med = lambda v: sorted(v)[len(v) // 2]
    print(f"n = {k.shape[0]}, nnz = {k.nnz}, read {t_read:.2f} s")
    print(f"splu factor median {med(factor):.3f} s, solve median {med(solve):.3f} s, "
          f"factor+solve {med(factor) + med(solve):.3f} s, relative residual {res:.1e}")


if __name__ == "__main__":
    main()
