"""Versions and the median table of the FEM speed comparison (for scripts/fem_compare.py).

The summary groups the JSON lines of a run by side and thread count and prints, per group,
the median over rounds of each timing (each round's value is itself that side's median over
its repetitions in the round), as a Markdown table; then each side's factor + solve against
the Rust default's (`rust-split`) at the same thread count, scikit-fem's whole pipeline
against the Rust pipeline less its meshing (the Python side reads the mesh), and the Rust
bench's peak memory.
"""
import json
import statistics
from collections import defaultdict


def versions():
    import importlib.metadata as md

    for pkg in ("numpy", "scipy", "pypardiso", "mkl", "scikit-sparse", "scikit-fem"):
        try:
            print(f"{pkg} {md.version(pkg)}")
        except md.PackageNotFoundError:
            print(f"{pkg} (not installed)")
    try:
        import numpy as np

        cfg = np.show_config(mode="dicts")
        blas = cfg.get("Build Dependencies", {}).get("blas", {})
        print(f"numpy BLAS {blas.get('name', '?')} {blas.get('version', '')}".rstrip())
    except Exception as e:  # numpy < 1.25 has no mode="dicts"
        print(f"numpy BLAS unknown ({e})")


def threads_label(t):
    rayon = t.get("RAYON_NUM_THREADS") or "-"
    mkl = t.get("MKL_NUM_THREADS") or "-"
    omp = t.get("OMP_NUM_THREADS") or "-"
    if rayon == mkl == omp:
        return rayon
    return f"rayon {rayon} / MKL {mkl} / OMP {omp}"


COLUMNS = [
    ("mesh_s", "mesh"),
    ("assembly_s", "assembly"),
    ("analyze_s", "ordering + symbolic"),
    ("factor_s", "factor"),
    ("solve_s", "solve (2 cases)"),
    ("factor_solve_s", "factor + solve"),
    ("total_s", "total"),
]


def summary(path):
    groups = defaultdict(list)
    memory = []
    for line in open(path):
        line = line.strip()
        if not line.startswith("{"):
            continue
        row = json.loads(line)
        if row["side"] == "rust-memory":
            memory.append(row)
            continue
        groups[(row["side"], threads_label(row["threads"]))].append(row)
    head = ["side", "threads", "rounds"] + [c[1] for c in COLUMNS] + ["peak kPa / residual"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for (side, th), rows in sorted(groups.items(), key=lambda g: (g[0][1], g[0][0])):
        cells = [side, th, str(len(rows))]
        for key, _ in COLUMNS:
            vals = [r[key] for r in rows if r.get(key) is not None]
            cells.append(f"{statistics.median(vals):.3f}" if vals else "")
        extra = rows[-1].get("peak_kpa")
        res = [r["residual"] for r in rows if "residual" in r]
        cells.append(f"{extra:.4f}" if extra is not None else f"{max(res):.1e}" if res else "")
        print("| " + " | ".join(cells) + " |")
    med = {
        g: {k: statistics.median([r[k] for r in rows if r.get(k) is not None] or [float("nan")])
            for k in ("factor_solve_s", "total_s", "mesh_s")}
        for g, rows in groups.items()
    }
    print()
    print("| threads | side | factor + solve / rust-split's | whole pipeline / rust-split's |")
    print("|---|---|---|---|")
    for (side, th), m in sorted(med.items(), key=lambda g: (g[0][1], g[0][0])):
        ours = med.get(("rust-split", th))
        if ours is None or side == "rust-split":
            continue
        whole = ""
        if side == "skfem+cholmod":
            whole = f"{m['total_s'] / (ours['total_s'] - ours['mesh_s']):.2f}x"
        elif side.startswith("rust-"):
            whole = f"{m['total_s'] / ours['total_s']:.2f}x"
        print(f"| {th} | {side} | {m['factor_solve_s'] / ours['factor_solve_s']:.2f}x | {whole} |")
    if memory:
        print()
        print("| refine | DOFs | peak RSS (MiB) |")
        print("|---|---|---|")
        for r in memory:
            print(f"| {r['refine']} | {r['dofs']} | {r['peak_rss_mib']} |")
