//! The lumen's wall as oriented boundary edges, and what a collapse is measured by: the
//! enclosed area and the opening along a vertical line.
//!
//! The mesh lists the lumen's edges unordered and unoriented. Here each edge is oriented with
//! the lumen on its left (counter-clockwise around the lumen), found from the one element
//! that owns it (a counter-clockwise element has itself on the left of its own edges), so no
//! centre point is needed and any mesh reader's lumen works. The follower pressure
//! ([`super::follower_pressure`]) and the self-contact ([`super::self_contact`]) both build
//! on this.

use std::collections::HashMap;

use super::mesh::Mesh;
use super::solve_error::SolveError;

/// One wall edge from `a` to `b` with the lumen on its left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WallEdge {
    pub a: usize,
    pub b: usize,
    /// The element the edge bounds, and the local positions (0..4) of `a` and `b` in it.
    pub element: usize,
    pub local: [usize; 2],
}

/// The lumen's wall of a mesh.
#[derive(Debug, Clone, Default)]
pub struct LumenWall {
    pub edges: Vec<WallEdge>,
    /// Wall nodes (sorted) and, per wall node, the edge arriving at it and the one leaving
    /// it (`usize::MAX` where the wall is open).
    pub nodes: Vec<usize>,
    pub arriving: Vec<usize>,
    pub leaving: Vec<usize>,
}

impl LumenWall {
    /// Orient the mesh's lumen edges. An edge that is not the side of exactly one element,
    /// or a node where the wall branches, is an error naming the edge or node.
    pub fn new(mesh: &Mesh) -> Result<Self, SolveError> {
        let mut index: HashMap<(u32, u32), usize> = HashMap::new();
        for (k, &[a, b]) in mesh.lumen_edges.iter().enumerate() {
            if a == b || a as usize >= mesh.nodes.len() || b as usize >= mesh.nodes.len() {
                return Err(SolveError::BadLumen(format!(
                    "lumen edge {k} ({a}, {b}) does not join two nodes of the mesh"
                )));
            }
            if index.insert((a.min(b), a.max(b)), k).is_some() {
                return Err(SolveError::BadLumen(format!(
                    "lumen edge {k} ({a}, {b}) is listed twice"
                )));
            }
        }
        let mut owner: Vec<Vec<WallEdge>> = vec![Vec::new(); mesh.lumen_edges.len()];
        for (e, el) in mesh.elements.iter().enumerate() {
            for i in 0..4 {
                let j = (i + 1) % 4;
                let (p, q) = (el[i], el[j]);
                if let Some(&k) = index.get(&(p.min(q), p.max(q))) {
                    // The element is on the left of p -> q, so the lumen is on the left of
                    // q -> p.
                    owner[k].push(WallEdge {
                        a: q as usize,
                        b: p as usize,
                        element: e,
                        local: [j, i],
                    });
                }
            }
        }
        let mut edges = Vec::with_capacity(owner.len());
        for (k, found) in owner.iter().enumerate() {
            let [a, b] = mesh.lumen_edges[k];
            match found.as_slice() {
                [one] => edges.push(*one),
                _ => {
                    return Err(SolveError::BadLumen(format!(
                        "lumen edge {k} ({a}, {b}) is a side of {} elements, not of exactly one",
                        found.len()
                    )));
                }
            }
        }
        let mut nodes: Vec<usize> = edges.iter().flat_map(|e| [e.a, e.b]).collect();
        nodes.sort_unstable();
        nodes.dedup();
        let mut arriving = vec![usize::MAX; nodes.len()];
        let mut leaving = vec![usize::MAX; nodes.len()];
        for (k, e) in edges.iter().enumerate() {
            for (node, slot) in [(e.b, &mut arriving), (e.a, &mut leaving)] {
                let i = nodes.partition_point(|&n| n < node);
                if slot[i] != usize::MAX {
                    return Err(SolveError::BadLumen(format!(
                        "the lumen's wall branches at node {node}"
                    )));
                }
                slot[i] = k;
            }
        }
        Ok(Self {
            edges,
            nodes,
            arriving,
            leaving,
        })
    }

    /// Whether every wall node has an edge arriving and one leaving: a closed lumen, on
    /// which a uniform pressure is conservative.
    pub fn is_closed(&self) -> bool {
        !self.edges.is_empty()
            && self
                .arriving
                .iter()
                .chain(&self.leaving)
                .all(|&k| k != usize::MAX)
    }

    /// Current position of node `n`.
    pub fn at(mesh: &Mesh, u: &[f64], n: usize) -> [f64; 2] {
        [mesh.nodes[n][0] + u[2 * n], mesh.nodes[n][1] + u[2 * n + 1]]
    }

    /// Area enclosed by the wall in the deformed configuration (the shoelace sum over the
    /// oriented edges; positive for an open lumen, meaningful for a closed wall).
    pub fn area(&self, mesh: &Mesh, u: &[f64]) -> f64 {
        0.5 * self
            .edges
            .iter()
            .map(|e| {
                let (p, q) = (Self::at(mesh, u, e.a), Self::at(mesh, u, e.b));
                p[0] * q[1] - q[0] * p[1]
            })
            .sum::<f64>()
    }

    /// The lumen's opening along the vertical line at `x` (deformed): the highest crossing of
    /// an edge running right to left (the roof, for a counter-clockwise wall) minus the
    /// lowest crossing of an edge running left to right (the floor). Negative if the walls
    /// overlap there; `None` if the line misses the lumen.
    pub fn opening_at(&self, mesh: &Mesh, u: &[f64], x: f64) -> Option<f64> {
        let mut roof = f64::NEG_INFINITY;
        let mut floor = f64::INFINITY;
        for e in &self.edges {
            let (p, q) = (Self::at(mesh, u, e.a), Self::at(mesh, u, e.b));
            let (lo, hi) = (p[0].min(q[0]), p[0].max(q[0]));
            if !(lo <= x && x < hi) {
                continue;
            }
            let s = (x - p[0]) / (q[0] - p[0]);
            let y = p[1] + s * (q[1] - p[1]);
            if q[0] < p[0] {
                roof = roof.max(y);
            } else {
                floor = floor.min(y);
            }
        }
        (roof.is_finite() && floor.is_finite()).then_some(roof - floor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesher::test_artery_block;

    #[test]
    fn the_mesher_s_lumen_is_a_closed_counter_clockwise_wall() {
        let m = test_artery_block(0.006, 0.0026, 0.0006, 0.002);
        let w = LumenWall::new(&m).unwrap();
        assert!(w.is_closed());
        assert_eq!(w.edges.len(), m.lumen_edges.len());
        // Counter-clockwise around the lumen: the shoelace area is the polygon's, positive,
        // and close to the circle's (radius 2 mm).
        let u = vec![0.0; m.dofs()];
        let a = w.area(&m, &u);
        let circle = std::f64::consts::PI * 0.002f64.powi(2);
        assert!(a > 0.97 * circle && a < circle, "{a} vs {circle}");
        // Each edge's owner holds a and b at the recorded positions.
        for e in &w.edges {
            let el = m.elements[e.element];
            assert_eq!(el[e.local[0]] as usize, e.a);
            assert_eq!(el[e.local[1]] as usize, e.b);
        }
        // The opening through the centre (x = 20 mm) is the diameter, less the polygon's sag.
        let h = w.opening_at(&m, &u, 0.02 + 1e-7).unwrap();
        assert!(h > 0.0039 && h <= 0.004 + 1e-12, "{h}");
        assert!(w.opening_at(&m, &u, 0.001).is_none());
        // A vertical squeeze of the wall by 1 mm at the centre shows in the opening.
        let mut squeezed = u.clone();
        for &n in &w.nodes {
            let y = m.nodes[n][1] - 0.014;
            squeezed[2 * n + 1] = -0.25 * y;
        }
        let hs = w.opening_at(&m, &squeezed, 0.02 + 1e-7).unwrap();
        assert!((hs - 0.75 * h).abs() < 1e-9, "{hs} vs {h}");
    }

    #[test]
    fn a_bad_lumen_is_an_error_naming_the_edge() {
        let mut m = test_artery_block(0.006, 0.0026, 0.0006, 0.002);
        // An edge of the mesh's interior (a side of two elements).
        let el = m.elements[m.elements.len() / 2];
        m.lumen_edges.push([el[0], el[1]]);
        let err = LumenWall::new(&m).unwrap_err().to_string();
        assert!(err.contains("is a side of 2 elements"), "{err}");
        let mut m = test_artery_block(0.006, 0.0026, 0.0006, 0.002);
        let first = m.lumen_edges[0];
        m.lumen_edges.push([first[1], first[0]]);
        let err = LumenWall::new(&m).unwrap_err().to_string();
        assert!(err.contains("listed twice"), "{err}");
        let mut m = test_artery_block(0.006, 0.0026, 0.0006, 0.002);
        m.lumen_edges.push([0, u32::MAX]);
        let err = LumenWall::new(&m).unwrap_err().to_string();
        assert!(err.contains("does not join two nodes"), "{err}");
    }
}
