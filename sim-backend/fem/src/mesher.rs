//! Block-structured mesher: a rectangle of tissue with one circular feature made of
//! concentric layers (a lumen with wall and stenosis rings, or a solid tumour).
//!
//! Around the feature sits a square box meshed as an O-grid: rings of nodes at the layer radii
//! (several elements through each layer, however thin), then a graded blend from the outer
//! circle to the box. The rest of the rectangle is a tensor grid whose lines continue the
//! box's sides, graded from the box size near the feature to the far-field size at the
//! edges. A solid core is a structured square blended into its circle. Every element is a
//! counter-clockwise quad; all interfaces are conforming (materials are glued node to node).

use super::mesh::Mesh;

/// One concentric layer of the feature, from the previous radius out to `outer_radius_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    pub outer_radius_m: f64,
    /// Region index of its elements (index into the model's material list).
    pub region: u16,
}

/// The circular feature.
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    pub centre_x_m: f64,
    /// Depth of the centre below the top surface.
    pub centre_depth_m: f64,
    /// Radius of the hole (the lumen) or `None` for a solid first layer.
    pub lumen_radius_m: Option<f64>,
    /// Layers from the inside out; at least one, radii increasing.
    pub layers: Vec<Layer>,
}

/// Mesh density. Sizes are in m; each refinement level halves them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Density {
    /// Circumferential element size on the feature's outer circle.
    pub near_size_m: f64,
    /// Element size far from the feature.
    pub far_size_m: f64,
    /// Minimum number of elements through each layer of the feature.
    pub min_layer_elements: usize,
    /// Largest size ratio between neighbouring elements in the graded regions.
    pub growth: f64,
}

impl Density {
    /// Halve the sizes `levels` times.
    pub fn refined(&self, levels: u32) -> Density {
        let f = 0.5f64.powi(levels as i32);
        Density {
            near_size_m: self.near_size_m * f,
            far_size_m: self.far_size_m * f,
            min_layer_elements: self.min_layer_elements << levels,
            growth: self.growth,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("the block must have positive finite width and height")]
    BadBlock,
    #[error(
        "mesh sizes must be positive and finite, growth > 1 and at least one element per layer"
    )]
    BadDensity,
    #[error("the feature needs at least one layer with increasing radii")]
    BadLayers,
    #[error(
        "the feature (outer radius {outer_m} m) does not fit inside the block with room for its mesh: \
         at least {needed_m} m is needed between its centre and every edge, {room_m} m is available"
    )]
    NoRoom {
        outer_m: f64,
        needed_m: f64,
        room_m: f64,
    },
    #[error("the mesh would have at least {0} nodes; refuse more than {MAX_NODES}")]
    TooLarge(usize),
}

/// Refuse meshes that would exhaust memory.
pub const MAX_NODES: usize = 3_000_000;

/// Box half-size as a multiple of the outer radius, and the smallest acceptable multiple.
const BOX_FACTOR: f64 = 2.0;
const MIN_BOX_FACTOR: f64 = 1.15;

/// Positions 0 = s_0 < ... < s_n = len with the first step near `h0`, steps growing by at most
/// `growth` up to `h_max`, scaled to end exactly at `len`. Empty when `len` is ~0.
/// More than `MAX_NODES` steps is refused (`TooLarge`): a growth barely above 1 from a tiny
/// first step would otherwise loop and allocate for ever.
fn graded(len: f64, h0: f64, h_max: f64, growth: f64) -> Result<Vec<f64>, MeshError> {
    if len <= 1e-12 {
        return Ok(vec![0.0]);
    }
    let h_max = h_max.max(h0);
    let mut steps = Vec::new();
    let mut h = h0.min(len);
    let mut sum = 0.0;
    while sum + 0.5 * h < len {
        if steps.len() >= MAX_NODES {
            return Err(MeshError::TooLarge(usize::MAX));
        }
        steps.push(h);
        sum += h;
        h = (h * growth).min(h_max);
    }
    if steps.is_empty() {
        steps.push(len);
        sum = len;
    }
    let scale = len / sum;
    let mut out = Vec::with_capacity(steps.len() + 1);
    let mut s = 0.0;
    out.push(0.0);
    for st in steps {
        s += st * scale;
        out.push(s);
    }
    if let Some(last) = out.last_mut() {
        *last = len;
    }
    Ok(out)
}

/// Build the mesh of a `width_m` x `height_m` block (bottom at y = 0) with an optional feature.
pub fn mesh_block(
    width_m: f64,
    height_m: f64,
    feature: Option<&Feature>,
    density: &Density,
) -> Result<Mesh, MeshError> {
    if !(width_m.is_finite() && height_m.is_finite() && width_m > 0.0 && height_m > 0.0) {
        return Err(MeshError::BadBlock);
    }
    let d = density;
    if !(d.near_size_m.is_finite()
        && d.far_size_m.is_finite()
        && d.near_size_m > 0.0
        && d.far_size_m > 0.0
        && d.growth.is_finite()
        && d.growth > 1.0
        && d.min_layer_elements >= 1)
    {
        return Err(MeshError::BadDensity);
    }
    check_size(width_m, height_m, feature, density)?;
    match feature {
        None => plain_block(width_m, height_m, d),
        Some(f) => feature_block(width_m, height_m, f, d),
    }
}

/// Refuse, without allocating, a mesh certainly larger than [`MAX_NODES`]: a lower bound of
/// its node count from the block, the feature and the density alone (the mesher's own guard
/// then counts exactly). Validation of a model calls this too, so that a model file whose
/// mesh cannot be built is refused when it is read. Sizes the mesher refuses for another
/// reason (no room, bad layers) pass here.
pub fn check_size(
    width_m: f64,
    height_m: f64,
    feature: Option<&Feature>,
    d: &Density,
) -> Result<(), MeshError> {
    let lower = match feature {
        None => {
            let s = d.near_size_m.max(d.far_size_m * 0.5);
            let nx = (width_m / s).ceil().max(2.0);
            let ny = (height_m / s).ceil().max(2.0);
            (nx + 1.0) * (ny + 1.0)
        }
        Some(f) => {
            let Some(r_out) = f.layers.last().map(|l| l.outer_radius_m) else {
                return Ok(());
            };
            let cx = f.centre_x_m;
            let cy = height_m - f.centre_depth_m;
            let room = cx.min(width_m - cx).min(cy).min(height_m - cy);
            if !(room.is_finite() && r_out.is_finite() && room >= MIN_BOX_FACTOR * r_out) {
                return Ok(());
            }
            let half = if 0.85 * room >= MIN_BOX_FACTOR * r_out {
                (BOX_FACTOR * r_out).min(0.85 * room)
            } else {
                room
            };
            let nq = (std::f64::consts::FRAC_PI_2 * r_out / d.near_size_m)
                .ceil()
                .max(4.0);
            // Grid lines: the box's, plus each side's graded steps (none longer than hm).
            let hm = d.far_size_m.max(2.0 * half / nq);
            let steps = |len: f64| (len / hm - 0.5).max(0.0);
            let lines_x = nq + 1.0 + steps(cx - half) + steps(width_m - cx - half);
            let lines_y = nq + 1.0 + steps(cy - half) + steps(height_m - cy - half);
            lines_x * lines_y
        }
    };
    if lower <= MAX_NODES as f64 {
        Ok(())
    } else {
        // Saturating: an infinite or huge bound reads as usize::MAX.
        Err(MeshError::TooLarge(lower as usize))
    }
}

fn estimate_guard(nx: usize, ny: usize) -> Result<(), MeshError> {
    let n = nx.saturating_mul(ny);
    if n > MAX_NODES {
        Err(MeshError::TooLarge(n))
    } else {
        Ok(())
    }
}

/// A block with no feature: a uniform tensor grid at the near size (the tissue-only model
/// must resolve the same surface as the others).
fn plain_block(w: f64, h: f64, d: &Density) -> Result<Mesh, MeshError> {
    let nx = ((w / d.near_size_m.max(d.far_size_m * 0.5)).ceil() as usize).max(2);
    let ny = ((h / d.near_size_m.max(d.far_size_m * 0.5)).ceil() as usize).max(2);
    estimate_guard(nx + 1, ny + 1)?;
    let xs: Vec<f64> = (0..=nx).map(|i| w * i as f64 / nx as f64).collect();
    let ys: Vec<f64> = (0..=ny).map(|j| h * j as f64 / ny as f64).collect();
    let mut grid = Grid::new(xs, ys, None);
    let mut mesh = Mesh::default();
    grid.emit(&mut mesh);
    Ok(mesh)
}

/// Tensor grid of the outer blocks; `hole` = index ranges (i0, i1, j0, j1) of the box, whose
/// strict interior holds no grid nodes.
struct Grid {
    xs: Vec<f64>,
    ys: Vec<f64>,
    hole: Option<(usize, usize, usize, usize)>,
    ids: Vec<u32>,
}

impl Grid {
    fn new(xs: Vec<f64>, ys: Vec<f64>, hole: Option<(usize, usize, usize, usize)>) -> Self {
        let n = xs.len() * ys.len();
        Self {
            xs,
            ys,
            hole,
            ids: vec![u32::MAX; n],
        }
    }

    fn inside_hole(&self, i: usize, j: usize) -> bool {
        matches!(self.hole, Some((i0, i1, j0, j1)) if i > i0 && i < i1 && j > j0 && j < j1)
    }

    fn cell_in_hole(&self, i: usize, j: usize) -> bool {
        matches!(self.hole, Some((i0, i1, j0, j1)) if i >= i0 && i < i1 && j >= j0 && j < j1)
    }

    fn id(&self, i: usize, j: usize) -> u32 {
        self.ids[j * self.xs.len() + i]
    }

    /// Create the grid's nodes and elements; top/bottom node lists are filled from it.
    fn emit(&mut self, mesh: &mut Mesh) {
        let nx = self.xs.len();
        for j in 0..self.ys.len() {
            for i in 0..nx {
                if !self.inside_hole(i, j) {
                    self.ids[j * nx + i] = mesh.nodes.len() as u32;
                    mesh.nodes.push([self.xs[i], self.ys[j]]);
                }
            }
        }
        for j in 0..self.ys.len() - 1 {
            for i in 0..nx - 1 {
                if self.cell_in_hole(i, j) {
                    continue;
                }
                mesh.elements.push([
                    self.id(i, j),
                    self.id(i + 1, j),
                    self.id(i + 1, j + 1),
                    self.id(i, j + 1),
                ]);
                mesh.region.push(0);
            }
        }
        let top = self.ys.len() - 1;
        mesh.top = (0..nx).map(|i| self.id(i, top)).collect();
        mesh.bottom = (0..nx).map(|i| self.id(i, 0)).collect();
    }
}

fn feature_block(w: f64, h: f64, f: &Feature, d: &Density) -> Result<Mesh, MeshError> {
    let mut radii = Vec::new();
    if let Some(r) = f.lumen_radius_m {
        radii.push(r);
    }
    let mut prev = f.lumen_radius_m.unwrap_or(0.0);
    for l in &f.layers {
        if !(l.outer_radius_m.is_finite() && l.outer_radius_m > prev) {
            return Err(MeshError::BadLayers);
        }
        prev = l.outer_radius_m;
        radii.push(prev);
    }
    if f.layers.is_empty() || radii[0].is_nan() || radii[0] <= 0.0 {
        return Err(MeshError::BadLayers);
    }
    let r_out = prev;
    let cx = f.centre_x_m;
    let cy = h - f.centre_depth_m;
    let room = cx.min(w - cx).min(cy).min(h - cy);
    if !(room.is_finite() && room >= MIN_BOX_FACTOR * r_out) {
        return Err(MeshError::NoRoom {
            outer_m: r_out,
            needed_m: MIN_BOX_FACTOR * r_out,
            room_m: room,
        });
    }
    // Keep a band of tensor-grid rows between the box and the block's edges when there is
    // room: the O-grid's skewed corner elements then never touch the surface where the
    // stresses are read.
    let half = if 0.85 * room >= MIN_BOX_FACTOR * r_out {
        (BOX_FACTOR * r_out).min(0.85 * room)
    } else {
        room
    };

    // Segments per box side (a quarter of the circumference); even for symmetry.
    let mut nq = ((std::f64::consts::FRAC_PI_2 * r_out / d.near_size_m).ceil() as usize).max(4);
    nq += nq % 2;
    let box_step = 2.0 * half / nq as f64;

    // Tensor-grid lines: graded outward from the box.
    let side = |len: f64| graded(len, box_step, d.far_size_m, d.growth);
    let left = side(cx - half)?;
    let right = side(w - cx - half)?;
    let below = side(cy - half)?;
    let above = side(h - cy - half)?;
    let mut xs: Vec<f64> = left.iter().rev().map(|s| cx - half - s).collect();
    let i0 = xs.len() - 1;
    xs.extend((1..=nq).map(|k| cx - half + box_step * k as f64));
    let i1 = xs.len() - 1;
    xs.extend(right.iter().skip(1).map(|s| cx + half + s));
    let mut ys: Vec<f64> = below.iter().rev().map(|s| cy - half - s).collect();
    let j0 = ys.len() - 1;
    ys.extend((1..=nq).map(|k| cy - half + box_step * k as f64));
    let j1 = ys.len() - 1;
    ys.extend(above.iter().skip(1).map(|s| cy + half + s));
    // Snap the outer edges exactly.
    xs[0] = 0.0;
    if let Some(x) = xs.last_mut() {
        *x = w;
    }
    ys[0] = 0.0;
    if let Some(y) = ys.last_mut() {
        *y = h;
    }

    // Radial levels inside the O-grid: through each layer, then out to the box.
    let n_around = 4 * nq;
    let circ = |r: f64| 2.0 * std::f64::consts::PI * r / n_around as f64;
    // Each level: (radius or None for the box, region of the elements outside it).
    let mut levels: Vec<f64> = Vec::new(); // radii of ring levels, inside out
    let mut level_region: Vec<u16> = Vec::new(); // region of the elements between level k and k+1
    let first_r = radii[0];
    levels.push(first_r);
    let layer_start = usize::from(f.lumen_radius_m.is_none());
    let mut r_prev = first_r;
    for l in &f.layers[layer_start..] {
        let t = l.outer_radius_m - r_prev;
        let n = d
            .min_layer_elements
            .max((t / circ(r_prev.max(l.outer_radius_m * 0.5))).ceil() as usize);
        for k in 1..=n {
            levels.push(r_prev + t * k as f64 / n as f64);
            level_region.push(l.region);
        }
        r_prev = l.outer_radius_m;
    }
    // Tissue between the outer circle and the box: geometric grading from the circle.
    let gap = half - r_out;
    // First blend layer about as thick as the circumferential size: near-square elements.
    let h0 = circ(r_out);
    let blend = graded(gap, h0, box_step, d.growth)?;
    let n_blend = blend.len() - 1;
    estimate_guard(
        (xs.len().saturating_mul(ys.len()))
            .saturating_add(n_around.saturating_mul(levels.len() + n_blend + 1))
            .saturating_add((nq + 1).saturating_mul(nq + 1)),
        1,
    )?;

    let mut grid = Grid::new(xs, ys, Some((i0, i1, j0, j1)));
    let mut mesh = Mesh::default();
    grid.emit(&mut mesh);

    // Box perimeter, counter-clockwise from the bottom-left corner.
    let perimeter_ij: Vec<(usize, usize)> = (0..n_around)
        .map(|k| {
            let (s, t) = (k / nq, k % nq);
            match s {
                0 => (i0 + t, j0),
                1 => (i1, j0 + t),
                2 => (i1 - t, j1),
                _ => (i0, j1 - t),
            }
        })
        .collect();
    let perimeter: Vec<u32> = perimeter_ij.iter().map(|&(i, j)| grid.id(i, j)).collect();
    let box_xy: Vec<[f64; 2]> = perimeter_ij
        .iter()
        .map(|&(i, j)| [grid.xs[i], grid.ys[j]])
        .collect();
    let angle = |k: usize| {
        -3.0 * std::f64::consts::FRAC_PI_4 + std::f64::consts::TAU * k as f64 / n_around as f64
    };
    let on_circle = |r: f64, k: usize| {
        let a = angle(k);
        [cx + r * a.cos(), cy + r * a.sin()]
    };

    // Ring levels (inside out) as node-id lists.
    let mut rings: Vec<Vec<u32>> = Vec::new();
    let push_ring = |mesh: &mut Mesh, pts: &mut dyn FnMut(usize) -> [f64; 2]| {
        let ids: Vec<u32> = (0..n_around)
            .map(|k| {
                mesh.nodes.push(pts(k));
                (mesh.nodes.len() - 1) as u32
            })
            .collect();
        ids
    };

    // Solid core: a structured square blended into the first circle.
    if f.lumen_radius_m.is_none() {
        let core_region = f.layers[0].region;
        let s0 = 0.5 * first_r;
        let sq_step = 2.0 * s0 / nq as f64;
        let mut core = vec![0u32; (nq + 1) * (nq + 1)];
        for j in 0..=nq {
            for i in 0..=nq {
                core[j * (nq + 1) + i] = mesh.nodes.len() as u32;
                mesh.nodes
                    .push([cx - s0 + sq_step * i as f64, cy - s0 + sq_step * j as f64]);
            }
        }
        for j in 0..nq {
            for i in 0..nq {
                let id = |i: usize, j: usize| core[j * (nq + 1) + i];
                mesh.elements
                    .push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                mesh.region.push(core_region);
            }
        }
        let sq_perim: Vec<u32> = (0..n_around)
            .map(|k| {
                let (s, t) = (k / nq, k % nq);
                let (i, j) = match s {
                    0 => (t, 0),
                    1 => (nq, t),
                    2 => (nq - t, nq),
                    _ => (0, nq - t),
                };
                core[j * (nq + 1) + i]
            })
            .collect();
        let n_core = d
            .min_layer_elements
            .max(((first_r - s0 * std::f64::consts::SQRT_2 * 0.8) / circ(first_r)).ceil() as usize);
        let sq_xy: Vec<[f64; 2]> = sq_perim.iter().map(|&i| mesh.nodes[i as usize]).collect();
        rings.push(sq_perim);
        for m in 1..=n_core {
            let s = m as f64 / n_core as f64;
            let ring = push_ring(&mut mesh, &mut |k| {
                let c = on_circle(first_r, k);
                [
                    (1.0 - s) * sq_xy[k][0] + s * c[0],
                    (1.0 - s) * sq_xy[k][1] + s * c[1],
                ]
            });
            rings.push(ring);
        }
        let mut regions = vec![core_region; n_core];
        regions.extend(level_region.iter().copied());
        level_region = regions;
        // `levels[0]` (first_r) is now the last core ring.
        for &r in &levels[1..] {
            let ring = push_ring(&mut mesh, &mut |k| on_circle(r, k));
            rings.push(ring);
        }
    } else {
        for &r in &levels {
            let ring = push_ring(&mut mesh, &mut |k| on_circle(r, k));
            rings.push(ring);
        }
        let lumen = &rings[0];
        mesh.lumen_edges = (0..n_around)
            .map(|k| [lumen[k], lumen[(k + 1) % n_around]])
            .collect();
    }
    // Blend from the outer circle to the box.
    for (m, s) in blend.iter().enumerate().skip(1) {
        let s = s / gap;
        if m == n_blend {
            rings.push(perimeter.clone());
        } else {
            let ring = push_ring(&mut mesh, &mut |k| {
                let c = on_circle(r_out, k);
                [
                    (1.0 - s) * c[0] + s * box_xy[k][0],
                    (1.0 - s) * c[1] + s * box_xy[k][1],
                ]
            });
            rings.push(ring);
        }
        level_region.push(0);
    }
    for (lv, region) in level_region.iter().enumerate() {
        let (inner, outer) = (&rings[lv], &rings[lv + 1]);
        for k in 0..n_around {
            let k1 = (k + 1) % n_around;
            mesh.elements
                .push([inner[k], outer[k], outer[k1], inner[k1]]);
            mesh.region.push(*region);
        }
    }
    // Ring elements were pushed (inner k, outer k, outer k+1, inner k+1): that is clockwise
    // for counter-clockwise k; fix orientation generically.
    for e in 0..mesh.elements.len() {
        if mesh.signed_area(e) < 0.0 {
            mesh.elements[e].swap(1, 3);
        }
    }
    mesh.feature_centre = Some([cx, cy]);
    Ok(mesh)
}

/// A 40 x 20 mm block with one artery 20 mm from its left edge (lumen radius 2 mm, the wall
/// region 1 out to `outer_radius_m`): the mesh the FEM's unit tests share.
#[cfg(test)]
pub(crate) fn test_artery_block(
    centre_depth_m: f64,
    outer_radius_m: f64,
    near_size_m: f64,
    far_size_m: f64,
) -> super::mesh::Mesh {
    let f = Feature {
        centre_x_m: 0.02,
        centre_depth_m,
        lumen_radius_m: Some(0.002),
        layers: vec![Layer {
            outer_radius_m,
            region: 1,
        }],
    };
    let d = Density {
        near_size_m,
        far_size_m,
        min_layer_elements: 2,
        growth: 1.3,
    };
    mesh_block(0.04, 0.02, Some(&f), &d).expect("the test block meshes")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn density() -> Density {
        Density {
            near_size_m: 0.0008,
            far_size_m: 0.004,
            min_layer_elements: 3,
            growth: 1.25,
        }
    }

    fn check_mesh(m: &Mesh, w: f64, h: f64) {
        // Orientation and positive Jacobians at every Gauss point.
        for e in 0..m.elements.len() {
            let q = crate::element::Q4::new(&m.element_coords(e));
            assert!(q.is_ok(), "element {e} degenerate");
        }
        // Total area equals the block area minus the lumen (polygon).
        let area: f64 = (0..m.elements.len()).map(|e| m.signed_area(e)).sum();
        let mut lumen = 0.0;
        if let Some(c) = m.feature_centre {
            for &[a, b] in &m.lumen_edges {
                let (pa, pb) = (m.nodes[a as usize], m.nodes[b as usize]);
                lumen +=
                    0.5 * ((pa[0] - c[0]) * (pb[1] - c[1]) - (pb[0] - c[0]) * (pa[1] - c[1])).abs();
            }
        }
        assert!(
            (area + lumen - w * h).abs() < 1e-9 * w * h,
            "area {area} + lumen {lumen} != {}",
            w * h
        );
        // Conformity: every interior edge is shared by exactly two elements; boundary edges
        // lie on the block's sides or the lumen.
        let mut edges = std::collections::HashMap::new();
        for el in &m.elements {
            for i in 0..4 {
                let (a, b) = (el[i], el[(i + 1) % 4]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let lumen_set: std::collections::HashSet<_> = m
            .lumen_edges
            .iter()
            .map(|&[a, b]| (a.min(b), a.max(b)))
            .collect();
        for (&(a, b), &count) in &edges {
            assert!(count <= 2);
            if count == 1 && !lumen_set.contains(&(a, b)) {
                let (pa, pb) = (m.nodes[a as usize], m.nodes[b as usize]);
                let on = |p: [f64; 2]| {
                    p[0].abs() < 1e-12
                        || (p[0] - w).abs() < 1e-12
                        || p[1].abs() < 1e-12
                        || (p[1] - h).abs() < 1e-12
                };
                assert!(on(pa) && on(pb), "hanging edge {pa:?}-{pb:?}");
            }
        }
        // Top nodes sorted and on the top.
        for pair in m.top.windows(2) {
            assert!(m.nodes[pair[0] as usize][0] < m.nodes[pair[1] as usize][0]);
        }
        assert!(
            m.top
                .iter()
                .all(|&n| (m.nodes[n as usize][1] - h).abs() < 1e-12)
        );
    }

    #[test]
    fn artery_with_stenosis_is_conforming_and_fills_the_block() {
        let f = Feature {
            centre_x_m: 0.04,
            centre_depth_m: 0.015,
            lumen_radius_m: Some(0.003),
            layers: vec![
                Layer {
                    outer_radius_m: 0.004,
                    region: 2,
                },
                Layer {
                    outer_radius_m: 0.005,
                    region: 1,
                },
            ],
        };
        let m = mesh_block(0.08, 0.03, Some(&f), &density()).unwrap();
        check_mesh(&m, 0.08, 0.03);
        assert_eq!(m.region.iter().filter(|&&r| r == 2).count() % 3, 0);
        assert!(!m.lumen_edges.is_empty());
    }

    #[test]
    fn solid_tumour_and_shallow_thin_walled_tube() {
        let tumour = Feature {
            centre_x_m: 0.04,
            centre_depth_m: 0.015,
            lumen_radius_m: None,
            layers: vec![Layer {
                outer_radius_m: 0.005,
                region: 1,
            }],
        };
        let m = mesh_block(0.08, 0.03, Some(&tumour), &density()).unwrap();
        check_mesh(&m, 0.08, 0.03);
        assert!(m.lumen_edges.is_empty());
        // A 0.63 mm wall close to the surface: the box touches the top.
        let tube = Feature {
            centre_x_m: 0.04,
            centre_depth_m: 0.0035,
            lumen_radius_m: Some(0.00225),
            layers: vec![Layer {
                outer_radius_m: 0.00288,
                region: 1,
            }],
        };
        let m = mesh_block(0.08, 0.03, Some(&tube), &density()).unwrap();
        check_mesh(&m, 0.08, 0.03);
        let wall = m.region.iter().filter(|&&r| r == 1).count();
        assert!(wall >= 3 * 16, "{wall} wall elements");
    }

    #[test]
    fn feature_too_close_to_an_edge_is_refused() {
        let f = Feature {
            centre_x_m: 0.04,
            centre_depth_m: 0.0051,
            lumen_radius_m: Some(0.004),
            layers: vec![Layer {
                outer_radius_m: 0.005,
                region: 1,
            }],
        };
        assert!(matches!(
            mesh_block(0.08, 0.03, Some(&f), &density()),
            Err(MeshError::NoRoom { .. })
        ));
    }

    #[test]
    fn plain_block_and_grading() {
        let m = mesh_block(0.08, 0.03, None, &density()).unwrap();
        check_mesh(&m, 0.08, 0.03);
        let g = graded(1.0, 0.01, 0.2, 1.2).unwrap();
        assert_eq!(g[0], 0.0);
        assert_eq!(*g.last().unwrap(), 1.0);
        for w in g.windows(3) {
            let r = (w[2] - w[1]) / (w[1] - w[0]);
            assert!(r <= 1.2 + 1e-9, "growth {r}");
        }
    }

    /// Found with the `fem_model_loader` fuzz target: sizes that the mesher must refuse
    /// quickly, without overflowing or allocating first.
    #[test]
    fn huge_meshes_are_refused_before_anything_is_allocated() {
        assert!(matches!(
            mesh_block(1e30, 0.03, None, &density()),
            Err(MeshError::TooLarge(_))
        ));
        let tube = |centre_x_m: f64, outer: f64| Feature {
            centre_x_m,
            centre_depth_m: 0.015,
            lumen_radius_m: Some(0.8 * outer),
            layers: vec![Layer {
                outer_radius_m: outer,
                region: 1,
            }],
        };
        assert!(matches!(
            mesh_block(1e5, 0.03, Some(&tube(5e4, 0.005)), &density()),
            Err(MeshError::TooLarge(_))
        ));
        // A tiny tube graded out with a growth barely above 1: every step the same tiny
        // size, far too many to list.
        let creeping = Density {
            growth: 1.0 + 1e-12,
            ..density()
        };
        assert!(matches!(
            mesh_block(0.08, 0.03, Some(&tube(0.04, 1e-9)), &creeping),
            Err(MeshError::TooLarge(_))
        ));
        assert_eq!(
            check_size(0.08, 0.03, Some(&tube(0.04, 0.005)), &density()),
            Ok(())
        );
    }
}
