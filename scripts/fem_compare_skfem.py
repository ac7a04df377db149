"""The whole linear solve of the seed001 bench redone in Python (for scripts/fem_compare.py):
scikit-fem assembles plane-stress elasticity with bilinear quadrilaterals on the exported mesh,
one basis per material region; the supports and platen displacement are imposed by
condensation; CHOLMOD factors once and solves both load cases (platen, unit lumen pressure);
the top-edge von Mises at t = 0.425 s is recovered as the Rust side does (2x2 Gauss stresses
extrapolated bilinearly to the nodes, averaged over the elements sharing each top node).

Not included, as on the timed Python side of the solvers: making the mesh (read from the
export) and the lumen pressure's nodal forces (taken from the export's dofs.txt: one line of
arithmetic per lumen edge). Checked against the export: the condensed K and the peak.
"""
import time

import numpy as np

G = 1.0 / np.sqrt(3.0)
# Reference corners, counter-clockwise; the Gauss points in the same pattern.
CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


def read(d):
    nodes = np.loadtxt(f"{d}/nodes.txt")
    el = np.loadtxt(f"{d}/elements.txt", dtype=np.int64)
    mats = np.loadtxt(f"{d}/materials.txt", ndmin=2)
    dofs = np.loadtxt(f"{d}/dofs.txt")
    top = np.loadtxt(f"{d}/top.txt", dtype=np.int64)
    case = dict(line.split() for line in open(f"{d}/case.txt"))
    if case["analysis"] != "PlaneStress":
        raise SystemExit(f"{d}: the scikit-fem pipeline is written for plane stress")
    return nodes, el, mats, dofs, top, case


def shape_grads(xi, eta):
    """dN/dξ and dN/dη of the four bilinear shape functions, shape (2, 4)."""
    s, t = CORNERS[:, 0], CORNERS[:, 1]
    return np.array([0.25 * s * (1 + t * eta), 0.25 * t * (1 + s * xi)])


def top_von_mises(nodes, el, mats, u, top):
    """Recovered von Mises at the top nodes (u: DOF 2n + c, as the Rust side numbers them)."""
    slot = np.full(len(nodes), -1)
    slot[top] = np.arange(len(top))
    touch = np.flatnonzero((slot[el[:, :4]] >= 0).any(axis=1))
    conn = el[touch, :4]
    x = nodes[conn]  # (m, 4, 2)
    ue = np.stack([u[2 * conn], u[2 * conn + 1]], axis=-1)
    e_pa, nu = mats[el[touch, 4], 0], mats[el[touch, 4], 1]
    c = e_pa / (1 - nu**2)
    gauss = []
    for xi, eta in G * CORNERS:
        dn = shape_grads(xi, eta)  # (2, 4)
        jac = np.einsum("ak,mkb->mab", dn, x)  # d(x, y)/d(ξ, η)
        dxy = np.linalg.solve(jac, np.broadcast_to(dn, (len(conn), 2, 4)))
        exx = np.einsum("mk,mk->m", dxy[:, 0], ue[..., 0])
        eyy = np.einsum("mk,mk->m", dxy[:, 1], ue[..., 1])
        gxy = np.einsum("mk,mk->m", dxy[:, 1], ue[..., 0]) + np.einsum(
            "mk,mk->m", dxy[:, 0], ue[..., 1]
        )
        gauss.append([c * (exx + nu * eyy), c * (nu * exx + eyy), c * 0.5 * (1 - nu) * gxy])
    gauss = np.array(gauss)  # (4 points, 3 components, m)
    # Bilinear extrapolation: a corner is at (±√3, ±√3) in the Gauss points' coordinates.
    s, t = CORNERS[:, 0], CORNERS[:, 1]
    ext = 0.25 * (1 + np.outer(s * np.sqrt(3), s)) * (1 + np.outer(t * np.sqrt(3), t))
    nodal = np.einsum("kj,jcm->mkc", ext, gauss)  # (m, 4 corners, 3)
    total = np.zeros((len(top), 3))
    count = np.zeros(len(top))
    for a in range(4):
        k = slot[conn[:, a]]
        on = k >= 0
        np.add.at(total, k[on], nodal[on, a])
        np.add.at(count, k[on], 1)
    sx, sy, txy = (total / np.maximum(count, 1)[:, None]).T
    return np.sqrt(sx**2 - sx * sy + sy**2 + 3 * txy**2)


def pipeline(d, data):
    import skfem
    from sksparse.cholmod import analyze
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    nodes, el, mats, dofs, top, case = data
    t = {}
    t0 = time.perf_counter()
    mesh = skfem.MeshQuad(nodes.T.copy(), el[:, :4].T.copy())
    element = skfem.ElementVector(skfem.ElementQuad1())
    k = None
    for r, (e_pa, nu) in enumerate(mats):
        idx = np.flatnonzero(el[:, 4] == r)
        if len(idx) == 0:
            continue
        lam, mu = lame_parameters(e_pa, nu)
        lam = 2 * lam * mu / (lam + 2 * mu)  # plane stress
        basis = skfem.Basis(mesh, element, elements=idx, intorder=2)
        part = skfem.asm(linear_elasticity(lam, mu), basis)
        k = part if k is None else k + part
    t["assembly_s"] = time.perf_counter() - t0
    # Our DOF 2n + c is scikit-fem's nodal_dofs[c, n].
    nd = basis.nodal_dofs
    ours_to_sk = np.empty(2 * len(nodes), dtype=np.int64)
    ours_to_sk[0::2], ours_to_sk[1::2] = nd[0], nd[1]
    fixed = ours_to_sk[np.flatnonzero(dofs[:, 0] > 0.5)]
    prescribed = np.zeros(k.shape[0])
    prescribed[ours_to_sk] = dofs[:, 1]
    lumen = np.zeros(k.shape[0])
    lumen[ours_to_sk] = dofs[:, 2]
    t1 = time.perf_counter()
    kc, fc, _, free = skfem.condense(k, np.zeros(k.shape[0]), x=prescribed, D=fixed)
    f2 = np.column_stack([fc, lumen[free]])
    kc = kc.tocsc()
    t["condense_s"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    fac = analyze(kc)
    fac.cholesky_inplace(kc)
    t["factor_s"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    uc = fac(f2)
    u_platen, u_unit = prescribed.copy(), np.zeros(k.shape[0])
    u_platen[free], u_unit[free] = uc[:, 0], uc[:, 1]
    t["solve_s"] = time.perf_counter() - t3
    t4 = time.perf_counter()
    u = u_platen + float(case["p_sys_pa"]) * u_unit
    vm = top_von_mises(nodes, el, mats, u[ours_to_sk], top)
    t["recover_s"] = time.perf_counter() - t4
    t["total_s"] = time.perf_counter() - t0
    return t, float(vm.max()), kc, free, ours_to_sk


def check_k(d, kc, free, ours_to_sk):
    """Relative Frobenius difference between scikit-fem's condensed K and the export's."""
    import scipy.sparse as sp

    ref = sp.load_npz(f"{d}/k.npz").tocsc()
    # The export orders free DOFs by our numbering; map scikit-fem's onto it.
    sk_to_ours = np.empty_like(ours_to_sk)
    sk_to_ours[ours_to_sk] = np.arange(len(ours_to_sk))
    order = np.argsort(sk_to_ours[free])
    mine = kc[order][:, order]
    return float(sp.linalg.norm(mine - ref) / sp.linalg.norm(ref))


def run_skfem(d, reps, emit, median):
    import scipy.sparse.linalg  # noqa: F401  (sp.linalg.norm)

    data = read(d)
    runs = [pipeline(d, data) for _ in range(reps)]
    keys = runs[0][0].keys()
    med = {k: median([r[0][k] for r in runs]) for k in keys}
    _, peak, kc, free, o2s = runs[-1]
    emit(
        side="skfem+cholmod",
        n=kc.shape[0],
        reps=reps,
        factor_solve_s=median([r[0]["factor_s"] + r[0]["solve_s"] for r in runs]),
        peak_kpa=peak * 1e-3,
        peak_rust_kpa=float(data[5]["peak_top_von_mises_pa"]) * 1e-3,
        k_rel_diff=check_k(d, kc, free, o2s),
        **med,
    )
