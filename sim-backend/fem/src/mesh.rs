//! An unstructured Q4 mesh with the node and edge sets the loads and outputs need.

/// Quadrilateral mesh. Coordinates in m; `y` up; each element lists its nodes
/// counter-clockwise and carries a region index into the model's material list.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub nodes: Vec<[f64; 2]>,
    pub elements: Vec<[u32; 4]>,
    pub region: Vec<u16>,
    /// Nodes on the top surface, sorted by x.
    pub top: Vec<u32>,
    /// Nodes on the bottom surface, sorted by x.
    pub bottom: Vec<u32>,
    /// Edges of the lumen wall (pressure acts on them), each (a, b) with the solid on the
    /// outside of the lumen.
    pub lumen_edges: Vec<[u32; 2]>,
    /// Centre of the lumen or inclusion, if any.
    pub feature_centre: Option<[f64; 2]>,
}

impl Mesh {
    pub fn dofs(&self) -> usize {
        2 * self.nodes.len()
    }

    pub fn element_coords(&self, e: usize) -> [[f64; 2]; 4] {
        let n = self.elements[e];
        [
            self.nodes[n[0] as usize],
            self.nodes[n[1] as usize],
            self.nodes[n[2] as usize],
            self.nodes[n[3] as usize],
        ]
    }

    /// The top edge's nodes' x, measured from `x0` (the model's output origin), m.
    pub fn top_x_m(&self, x0: f64) -> Vec<f64> {
        self.top
            .iter()
            .map(|&n| self.nodes[n as usize][0] - x0)
            .collect()
    }

    /// Signed area of element `e` (positive when counter-clockwise).
    pub fn signed_area(&self, e: usize) -> f64 {
        let x = self.element_coords(e);
        let mut a = 0.0;
        for i in 0..4 {
            let j = (i + 1) % 4;
            a += x[i][0] * x[j][1] - x[j][0] * x[i][1];
        }
        0.5 * a
    }

    /// Nodal forces of a uniform pressure `p_pa` on the lumen wall, acting on the solid
    /// (pointing away from the lumen), per unit thickness. The load keeps its reference
    /// direction (no follower term) and its sum is exactly zero.
    pub fn lumen_pressure_forces(&self, p_pa: f64) -> Vec<f64> {
        let mut f = vec![0.0; self.dofs()];
        let Some(c) = self.feature_centre else {
            return f;
        };
        for &[a, b] in &self.lumen_edges {
            let (pa, pb) = (self.nodes[a as usize], self.nodes[b as usize]);
            let t = [pb[0] - pa[0], pb[1] - pa[1]];
            // Edge normal scaled by length; flip to point away from the lumen centre.
            let mut n = [t[1], -t[0]];
            let mid = [0.5 * (pa[0] + pb[0]) - c[0], 0.5 * (pa[1] + pb[1]) - c[1]];
            if n[0] * mid[0] + n[1] * mid[1] < 0.0 {
                n = [-n[0], -n[1]];
            }
            for node in [a, b] {
                f[2 * node as usize] += 0.5 * p_pa * n[0];
                f[2 * node as usize + 1] += 0.5 * p_pa * n[1];
            }
        }
        f
    }

    /// A quarter annulus a <= r <= b, 0 <= θ <= π/2, with `n_r` x `n_t` elements; the inner
    /// arc is the lumen. Used to verify against Lamé's thick cylinder.
    pub fn quarter_annulus(a: f64, b: f64, n_r: usize, n_t: usize) -> Mesh {
        Self::annulus(a, b, n_r, n_t, false)
    }

    /// A whole ring a <= r <= b with `n_r` x `n_t` elements (counter-clockwise), its inner
    /// circle the lumen.
    pub fn ring(a: f64, b: f64, n_r: usize, n_t: usize) -> Mesh {
        Self::annulus(a, b, n_r, n_t, true)
    }

    /// The quarter annulus, or with `closed` the whole ring (its last column of elements
    /// joins the first instead of ending on a new column of nodes).
    fn annulus(a: f64, b: f64, n_r: usize, n_t: usize, closed: bool) -> Mesh {
        let mut m = Mesh {
            feature_centre: Some([0.0, 0.0]),
            ..Mesh::default()
        };
        let (columns, sweep) = if closed {
            (n_t, std::f64::consts::TAU)
        } else {
            (n_t + 1, std::f64::consts::FRAC_PI_2)
        };
        let id = |i: usize, j: usize| ((j % columns) * (n_r + 1) + i) as u32;
        for j in 0..columns {
            let t = sweep * j as f64 / n_t as f64;
            for i in 0..=n_r {
                let r = a + (b - a) * i as f64 / n_r as f64;
                m.nodes.push([r * t.cos(), r * t.sin()]);
            }
        }
        for j in 0..n_t {
            for i in 0..n_r {
                m.elements
                    .push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                m.region.push(0);
            }
            m.lumen_edges.push([id(0, j), id(0, j + 1)]);
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lumen_pressure_has_zero_net_force_and_pushes_outward() {
        let m = Mesh::quarter_annulus(1.0, 2.0, 2, 8);
        let f = m.lumen_pressure_forces(1.0);
        // Quarter ring: net force is p·a along each axis (projection of the arc).
        let fx: f64 = f.iter().step_by(2).sum();
        let fy: f64 = f.iter().skip(1).step_by(2).sum();
        assert!((fx - 1.0).abs() < 1e-12, "{fx}");
        assert!((fy - 1.0).abs() < 1e-12, "{fy}");
        for e in 0..m.elements.len() {
            assert!(m.signed_area(e) > 0.0);
        }
    }
}
