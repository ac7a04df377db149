//! Geometric checks that make a Gmsh mesh fit the solver, and the boundary node sets they
//! yield. A mesh that parses can still be wrong for the model in ways the solve would not
//! report: drawn in millimetres, surfaces not fragmented (materials not glued), a "lumen"
//! on an interface, a "top" that is not the flat top. Each gives an error here.

use std::collections::HashMap;

use super::element::Q4;
use super::gmsh_build::{BOTTOM, Built, Expected, LUMEN, TOP};
use super::mesh::Mesh;

/// Finish `built` into the solver's mesh.
pub fn finish(built: Built, want: &Expected) -> Result<Mesh, String> {
    let Built {
        mut mesh,
        element_tags,
        lines,
    } = built;
    orient(&mut mesh, &element_tags)?;
    let tol = 1e-6 * want.width_m.max(want.height_m);
    check_extent(&mesh, want, tol)?;
    check_distinct_nodes(&mesh, tol)?;
    let edges = edge_owners(&mesh);
    let on_boundary = |g: &str| -> Result<Vec<[u32; 2]>, String> {
        let mut out = Vec::new();
        for &([a, b], tag) in lines.get(g).map_or(&[][..], Vec::as_slice) {
            match edges.get(&key(a, b)) {
                Some(&(1, _)) => out.push([a, b]),
                Some(_) => {
                    return Err(format!(
                        "line {tag} of \"{g}\" lies between two quadrilaterals: \"{g}\" must \
                         be on the mesh's boundary"
                    ));
                }
                None => {
                    return Err(format!(
                        "line {tag} of \"{g}\" is not an edge of any quadrilateral (its nodes \
                         are not neighbours in the mesh)"
                    ));
                }
            }
        }
        Ok(out)
    };
    mesh.top = row(&mesh, &on_boundary(TOP)?, TOP, want.height_m, tol)?;
    if mesh
        .top
        .first()
        .is_none_or(|&n| mesh.nodes[n as usize][0] > tol)
        || mesh
            .top
            .last()
            .is_none_or(|&n| mesh.nodes[n as usize][0] < want.width_m - tol)
    {
        return Err(format!(
            "\"{TOP}\" does not run the whole top edge, x = 0 to {} m",
            want.width_m
        ));
    }
    mesh.bottom = row(&mesh, &on_boundary(BOTTOM)?, BOTTOM, 0.0, tol)?;
    let lumen = on_boundary(LUMEN)?;
    if !lumen.is_empty() {
        let owner = |a: u32, b: u32| edges.get(&key(a, b)).map_or(0, |&(_, e)| e);
        mesh.feature_centre = Some(lumen_centre(&mesh, &lumen, owner)?);
        mesh.lumen_edges = lumen;
    }
    Ok(mesh)
}

/// Counter-clockwise elements, each with a positive Jacobian at its Gauss points.
fn orient(mesh: &mut Mesh, tags: &[u64]) -> Result<(), String> {
    for e in 0..mesh.elements.len() {
        if mesh.signed_area(e) < 0.0 {
            mesh.elements[e].reverse();
        }
        if Q4::new(&mesh.element_coords(e)).is_err() {
            return Err(format!(
                "quadrilateral {} is degenerate or not convex (a Jacobian is not positive)",
                tags.get(e).copied().unwrap_or_default()
            ));
        }
    }
    Ok(())
}

/// The mesh spans the model's block; a mesh drawn in millimetres is the usual miss.
fn check_extent(mesh: &Mesh, want: &Expected, tol: f64) -> Result<(), String> {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in &mesh.nodes {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let fits = lo.iter().all(|v| v.abs() <= tol)
        && (hi[0] - want.width_m).abs() <= tol
        && (hi[1] - want.height_m).abs() <= tol;
    if fits {
        return Ok(());
    }
    let hint = if hi[0] > 100.0 * want.width_m {
        " (coordinates are read in metres: is the mesh in millimetres?)"
    } else {
        ""
    };
    Err(format!(
        "the mesh spans x {} to {}, y {} to {} but the model's block is x 0 to {}, y 0 to {} m{hint}",
        lo[0], hi[0], lo[1], hi[1], want.width_m, want.height_m
    ))
}

/// No two nodes at one place: surfaces meshed apart (not fragmented) would leave their
/// materials unglued, and the solve would not say so. Nodes are binned in cells of `tol`
/// (a sweep along x would be quadratic on a structured grid's columns).
fn check_distinct_nodes(mesh: &Mesh, tol: f64) -> Result<(), String> {
    let cell = |v: f64| (v / tol).floor() as i64;
    let mut bins: HashMap<(i64, i64), Vec<usize>> = HashMap::with_capacity(mesh.nodes.len());
    for (i, p) in mesh.nodes.iter().enumerate() {
        let (cx, cy) = (cell(p[0]), cell(p[1]));
        for dx in -1..=1 {
            for dy in -1..=1 {
                let near = bins.get(&(cx + dx, cy + dy)).map_or(&[][..], Vec::as_slice);
                if near.iter().any(|&j| {
                    let q = mesh.nodes[j];
                    (q[0] - p[0]).abs() <= tol && (q[1] - p[1]).abs() <= tol
                }) {
                    return Err(format!(
                        "two nodes at ({}, {}): the surfaces are not conforming (in Gmsh, \
                         fragment them so that neighbouring materials share their nodes)",
                        p[0], p[1]
                    ));
                }
            }
        }
        bins.entry((cx, cy)).or_default().push(i);
    }
    Ok(())
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Each element edge: how many elements hold it, and one of them.
fn edge_owners(mesh: &Mesh) -> HashMap<(u32, u32), (u32, usize)> {
    let mut edges: HashMap<(u32, u32), (u32, usize)> = HashMap::new();
    for (e, el) in mesh.elements.iter().enumerate() {
        for i in 0..4 {
            let entry = edges.entry(key(el[i], el[(i + 1) % 4])).or_insert((0, e));
            entry.0 += 1;
        }
    }
    edges
}

/// The nodes of a straight horizontal boundary at `y`, sorted by x.
fn row(mesh: &Mesh, segs: &[[u32; 2]], name: &str, y: f64, tol: f64) -> Result<Vec<u32>, String> {
    let mut ids: Vec<u32> = segs.iter().flatten().copied().collect();
    if let Some(&off) = ids
        .iter()
        .find(|&&n| (mesh.nodes[n as usize][1] - y).abs() > tol)
    {
        let p = mesh.nodes[off as usize];
        return Err(format!(
            "\"{name}\" has a node at ({}, {}): it must lie on y = {y} m",
            p[0], p[1]
        ));
    }
    ids.sort_by(|&a, &b| mesh.nodes[a as usize][0].total_cmp(&mesh.nodes[b as usize][0]));
    ids.dedup();
    Ok(ids)
}

/// The lumen's centre (its edges' length-weighted midpoint), from which the pressure's
/// direction is taken ([`Mesh::lumen_pressure_forces`]): checked to point into the solid
/// at every edge, i.e. the lumen is one hole, star-shaped about it.
fn lumen_centre(
    mesh: &Mesh,
    lumen: &[[u32; 2]],
    owner: impl Fn(u32, u32) -> usize,
) -> Result<[f64; 2], String> {
    let mut c = [0.0; 2];
    let mut total = 0.0;
    for &[a, b] in lumen {
        let (pa, pb) = (mesh.nodes[a as usize], mesh.nodes[b as usize]);
        let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
        c[0] += len * 0.5 * (pa[0] + pb[0]);
        c[1] += len * 0.5 * (pa[1] + pb[1]);
        total += len;
    }
    let c = [c[0] / total, c[1] / total];
    for &[a, b] in lumen {
        let (pa, pb) = (mesh.nodes[a as usize], mesh.nodes[b as usize]);
        let mid = [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])];
        let el = mesh.element_coords(owner(a, b));
        let inside = [
            el.iter().map(|p| p[0]).sum::<f64>() / 4.0 - mid[0],
            el.iter().map(|p| p[1]).sum::<f64>() / 4.0 - mid[1],
        ];
        let away = [mid[0] - c[0], mid[1] - c[1]];
        // Both measured along the edge's normal.
        let n = [pb[1] - pa[1], pa[0] - pb[0]];
        let side = |v: [f64; 2]| v[0] * n[0] + v[1] * n[1];
        if side(inside) * side(away) <= 0.0 {
            return Err(format!(
                "the \"{LUMEN}\" edge at ({}, {}) faces away from the lumen's centre ({}, {}): \
                 the lumen must be a single hole, star-shaped about its centre",
                mid[0], mid[1], c[0], c[1]
            ));
        }
    }
    Ok(c)
}
