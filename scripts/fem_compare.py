#!/usr/bin/env python3
"""The Python side of the FEM speed comparison (run by scripts/fem_compare.sh, which sets up
its venv and the thread counts): the system and mesh exported by the seed001 bench
(`--export DIR`, files listed in sim-backend/fem/benches/export/mod.rs) solved with CHOLMOD
(scikit-sparse), PARDISO (pypardiso, MKL) and SuperLU (SciPy), and the whole linear solve
redone with scikit-fem. Every timing is a real measurement printed as one JSON line.

    fem_compare.py prepare DIR                      k.mtx -> k.npz (read once, not timed)
    fem_compare.py solvers DIR --reps N [--superlu]  factor and solve, both load cases
    fem_compare.py skfem DIR --reps N               assembly to top stresses with scikit-fem
    fem_compare.py rust --ordering O < bench output  the bench's last row as JSON
    fem_compare.py versions                         package, BLAS and MKL versions
    fem_compare.py summary RESULTS.jsonl            median table (Markdown)

Thread counts come from the environment (MKL_NUM_THREADS, OMP_NUM_THREADS,
OPENBLAS_NUM_THREADS, RAYON_NUM_THREADS) and are recorded in every line.
"""
import json
import os
import sys
import time

THREAD_VARS = ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "RAYON_NUM_THREADS")


def threads():
    return {k: os.environ.get(k, "") for k in THREAD_VARS}


def emit(**row):
    row["threads"] = threads()
    print(json.dumps(row), flush=True)


def median(v):
    v = sorted(v)
    return v[len(v) // 2] if v else float("nan")


def arg(name, default):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


def load_system(d):
    import numpy as np
    import scipy.sparse as sp

    k = sp.load_npz(f"{d}/k.npz").tocsc()
    f = np.column_stack([np.loadtxt(f"{d}/f.txt"), np.loadtxt(f"{d}/f_lumen.txt")])
    return k, f


def residual(k, u, f):
    import numpy as np

    return float(np.linalg.norm(k @ u - f) / np.linalg.norm(f))


def prepare(d):
    import scipy.io
    import scipy.sparse as sp

    lower = scipy.io.mmread(f"{d}/k.mtx").tocsc()  # mmread fills in the upper triangle
    sp.save_npz(f"{d}/k.npz", lower, compressed=False)
    print(f"{d}/k.npz: n = {lower.shape[0]}, nnz = {lower.nnz}")


def cholmod(k, f, ordering="default"):
    from sksparse.cholmod import analyze

    t0 = time.perf_counter()
    # "default": CHOLMOD tries AMD, and METIS as well if AMD fills a lot, and keeps the best.
    fac = analyze(k, ordering_method=ordering)
    t1 = time.perf_counter()
    fac.cholesky_inplace(k)
    t2 = time.perf_counter()
    u = fac(f)
    t3 = time.perf_counter()
    return t1 - t0, t2 - t1, t3 - t2, u


def pardiso(k, f):
    import pypardiso
    import scipy.sparse as sp

    s = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite
    upper = sp.triu(k, format="csr")
    t0 = time.perf_counter()
    s.factorize(upper)  # phase 12: METIS nested dissection, symbolic and numeric
    t2 = time.perf_counter()
    u = s.solve(upper, f)  # phase 33 with the kept factor
    t3 = time.perf_counter()
    s.free_memory(everything=True)
    return None, t2 - t0, t3 - t2, u


def superlu(k, f):
    import scipy.sparse.linalg as sla

    t0 = time.perf_counter()
    lu = sla.splu(k)  # default COLAMD ordering, as scripts/fem_superlu.py
    t2 = time.perf_counter()
    u = lu.solve(f)
    t3 = time.perf_counter()
    return None, t2 - t0, t3 - t2, u


def solvers(d):
    reps = int(arg("--reps", "3"))
    k, f = load_system(d)
    which = [
        ("cholmod", cholmod),
        ("cholmod-metis", lambda k, f: cholmod(k, f, "metis")),
        ("pardiso", pardiso),
    ]
    if "--superlu" in sys.argv:
        which.append(("superlu", superlu))
    for name, run in which:
        rows = [run(k, f) for _ in range(reps)]
        analyze = [r[0] for r in rows if r[0] is not None]
        factor = [(r[0] or 0.0) + r[1] for r in rows]
        solve = [r[2] for r in rows]
        both = [a + b for a, b in zip(factor, solve)]
        emit(
            side=name,
            n=k.shape[0],
            reps=reps,
            analyze_s=median(analyze) if analyze else None,
            factor_s=median(factor),
            solve_s=median(solve),
            factor_solve_s=median(both),
            residual=max(residual(k, r[3], f) for r in rows),
        )


def rust():
    """The bench's table: refine dofs mesh pattern assembly symbolic numeric solve recover
    total peak L-nnz GFlop; the last line is the finest level's medians."""
    cols = sys.stdin.read().strip().splitlines()[-1].split()
    v = [float(x) for x in cols]
    sym, num, sol = v[5], v[6], v[7]
    emit(
        side="rust-" + arg("--ordering", "split"),
        n=int(v[1]),
        reps=int(arg("--reps", "1")),
        mesh_s=v[2],
        pattern_s=v[3],
        assembly_s=v[4],
        analyze_s=sym,
        factor_s=sym + num,
        solve_s=sol,
        factor_solve_s=sym + num + sol,
        recover_s=v[8],
        total_s=v[9],
        peak_kpa=v[10],
        l_nnz_m=v[11],
        gflop=v[12],
    )


if __name__ == "__main__":
    cmd = sys.argv[1] if len(sys.argv) > 1 else ""
    if cmd == "prepare":
        prepare(sys.argv[2])
    elif cmd == "solvers":
        solvers(sys.argv[2])
    elif cmd == "skfem":
        from fem_compare_skfem import run_skfem

        run_skfem(sys.argv[2], int(arg("--reps", "3")), emit, median)
    elif cmd == "rust":
        rust()
    elif cmd == "versions":
        from fem_compare_report import versions

        versions()
    elif cmd == "summary":
        from fem_compare_report import summary

        summary(sys.argv[2])
    else:
        print(__doc__)
        sys.exit(2)
