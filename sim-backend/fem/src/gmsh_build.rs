//! A parsed `.msh` file (mshio's structure) made into the solver's [`Mesh`]: materials and
//! boundaries found by physical-group name, nodes renumbered to those the quadrilaterals
//! use, elements turned counter-clockwise.
//!
//! Node tags: mshio keeps a block's tags only when the file's tags are sparse; dense tags
//! (Gmsh's default numbering) it numbers in file order from the smallest, as Gmsh writes
//! them. The geometric checks in [`super::gmsh_check`] would catch a file that numbered
//! them otherwise (its boundary lines would not be element edges).

use std::collections::HashMap;

use mshio::mshfile::ElementType;

use super::gmsh_names::PhysicalNames;
use super::mesh::Mesh;

/// What the model expects of a Gmsh mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Expected {
    /// 2-D group names in the model's material order (region index = position).
    pub regions: Vec<String>,
    /// Whether the model holds the bottom (then a "bottom" group is needed).
    pub need_bottom: bool,
    /// Whether the model has a lumen (then a "lumen" group is needed).
    pub need_lumen: bool,
    /// The model's block: the mesh must span [0, width] x [0, height].
    pub width_m: f64,
    pub height_m: f64,
}

pub const TOP: &str = "top";
pub const BOTTOM: &str = "bottom";
pub const LUMEN: &str = "lumen";

/// Refuse meshes beyond the built-in mesher's limit.
pub const MAX_NODES: usize = super::mesher::MAX_NODES;

pub type Msh = mshio::MshFile<u64, i32, f64>;

/// The mesh, and for each of "top", "bottom", "lumen" its line elements (as mesh node
/// pairs) and the file's element tags (for messages).
#[derive(Debug, Default)]
pub struct Built {
    pub mesh: Mesh,
    /// File tag of each mesh element.
    pub element_tags: Vec<u64>,
    pub lines: HashMap<&'static str, Vec<([u32; 2], u64)>>,
}

/// Names of each (dimension, entity) pair's physical groups; unnamed groups are left out.
fn entity_groups(
    msh: &Msh,
    names: &PhysicalNames,
) -> Result<HashMap<(i32, i32), Vec<String>>, String> {
    let entities = msh.data.entities.as_ref().ok_or("no $Entities section")?;
    if let Some(v) = entities.volumes.first() {
        return Err(format!(
            "$Entities has volume {}: only 2-D meshes are read (mesh with `gmsh -2`)",
            v.tag
        ));
    }
    let mut out = HashMap::new();
    let mut add = |dim: i32, tag: i32, phys: &[i32]| {
        let named = phys
            .iter()
            .filter_map(|p| names.get(&(dim, p.saturating_abs())).cloned())
            .collect();
        out.insert((dim, tag), named);
    };
    for c in &entities.curves {
        add(1, c.tag, &c.physical_tags);
    }
    for s in &entities.surfaces {
        add(2, s.tag, &s.physical_tags);
    }
    Ok(out)
}

/// Node tag -> (x, y), checking the declared count, finiteness and z = 0.
fn node_coords(msh: &Msh) -> Result<HashMap<u64, [f64; 2]>, String> {
    let nodes = msh.data.nodes.as_ref().ok_or("no $Nodes section")?;
    let listed: usize = nodes.node_blocks.iter().map(|b| b.nodes.len()).sum();
    if u64::try_from(listed).ok() != Some(nodes.num_nodes) {
        return Err(format!(
            "$Nodes says it holds {} nodes but its blocks list {listed}",
            nodes.num_nodes
        ));
    }
    if listed > MAX_NODES {
        return Err(format!("{listed} nodes: more than the {MAX_NODES} solved"));
    }
    let mut coords = HashMap::with_capacity(listed);
    let mut next = nodes.min_node_tag;
    for block in &nodes.node_blocks {
        let mut tags = vec![0u64; block.nodes.len()];
        match &block.node_tags {
            Some(map) => {
                for (&t, &i) in map {
                    if let Some(slot) = tags.get_mut(i) {
                        *slot = t;
                    }
                }
            }
            None => {
                for t in &mut tags {
                    *t = next;
                    next = next.saturating_add(1);
                }
            }
        }
        for (&t, n) in tags.iter().zip(&block.nodes) {
            if t == 0 {
                return Err(format!(
                    "a node of entity {} (dimension {}) repeats a tag of its block",
                    block.entity_tag, block.entity_dim
                ));
            }
            if !(n.x.is_finite() && n.y.is_finite() && n.z.is_finite()) {
                return Err(format!("node {t} has a non-finite coordinate"));
            }
            if n.z.abs() > 1e-9 * (1.0 + n.x.abs().max(n.y.abs())) {
                return Err(format!(
                    "node {t} has z = {}: a 2-D mesh lies in the z = 0 plane",
                    n.z
                ));
            }
            if coords.insert(t, [n.x, n.y]).is_some() {
                return Err(format!("node tag {t} is listed twice in $Nodes"));
            }
        }
    }
    Ok(coords)
}

fn check_element_type(dim: i32, tag: i32, ty: ElementType) -> Result<(), String> {
    match (dim, ty) {
        (1, ElementType::Lin2) | (2, ElementType::Qua4) => Ok(()),
        (2, ElementType::Tri3) => Err(format!(
            "surface {tag} has triangles: only 4-node quadrilaterals are read; recombine \
             in Gmsh (Mesh.RecombineAll = 1, Mesh.RecombinationAlgorithm = 3 for all \
             quadrilaterals)"
        )),
        (2, other) => Err(format!(
            "surface {tag} has {other:?} elements: only first-order 4-node quadrilaterals \
             (Qua4) are read (Mesh.ElementOrder = 1)"
        )),
        (_, other) => Err(format!(
            "curve {tag} has {other:?} elements: only first-order 2-node lines (Lin2) are \
             read (Mesh.ElementOrder = 1)"
        )),
    }
}

/// The mesh of `msh` as the model expects it (boundaries not yet checked).
pub fn build(msh: &Msh, names: &PhysicalNames, want: &Expected) -> Result<Built, String> {
    let groups = entity_groups(msh, names)?;
    let coords = node_coords(msh)?;
    let elements = msh.data.elements.as_ref().ok_or("no $Elements section")?;
    let region_of: HashMap<&str, u16> = want
        .regions
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i as u16))
        .collect();
    let mut out = Built::default();
    let mut index: HashMap<u64, u32> = HashMap::new();
    let mut node_id = |t: u64, mesh: &mut Mesh, what: &str| -> Result<u32, String> {
        if let Some(&i) = index.get(&t) {
            return Ok(i);
        }
        let c = coords
            .get(&t)
            .ok_or_else(|| format!("{what} uses node {t}, which $Nodes does not list"))?;
        let i = mesh.nodes.len() as u32;
        mesh.nodes.push(*c);
        index.insert(t, i);
        Ok(i)
    };
    let mut seen = vec![false; want.regions.len()];
    let mut line_tags: Vec<(&'static str, [u64; 2], u64)> = Vec::new();
    for block in &elements.element_blocks {
        let (dim, tag) = (block.entity_dim, block.entity_tag);
        let names = groups.get(&(dim, tag)).map_or(&[][..], Vec::as_slice);
        match dim {
            0 => {}
            1 => {
                let wanted: Vec<&'static str> = [TOP, BOTTOM, LUMEN]
                    .into_iter()
                    .filter(|g| names.iter().any(|n| n == g))
                    .collect();
                if wanted.is_empty() {
                    continue;
                }
                check_element_type(dim, tag, block.element_type)?;
                for e in &block.elements {
                    let &[a, b] = e.nodes.as_slice() else {
                        return Err(format!("line {} does not have 2 nodes", e.element_tag));
                    };
                    for &g in &wanted {
                        line_tags.push((g, [a, b], e.element_tag));
                    }
                }
            }
            2 => {
                check_element_type(dim, tag, block.element_type)?;
                let regions: Vec<u16> = names
                    .iter()
                    .filter_map(|g| region_of.get(g.as_str()).copied())
                    .collect();
                let region = match regions[..] {
                    [r] => r,
                    [] => {
                        return Err(format!(
                            "surface {tag} is in no physical group named as one of the \
                             model's materials {:?} (its named groups: {names:?})",
                            want.regions
                        ));
                    }
                    _ => {
                        return Err(format!(
                            "surface {tag} is in more than one material group: {names:?}"
                        ));
                    }
                };
                seen[usize::from(region)] = true;
                for e in &block.elements {
                    let &[a, b, c, d] = e.nodes.as_slice() else {
                        return Err(format!(
                            "quadrilateral {} does not have 4 nodes",
                            e.element_tag
                        ));
                    };
                    let what = format!("quadrilateral {}", e.element_tag);
                    let mut el = [0u32; 4];
                    for (slot, t) in el.iter_mut().zip([a, b, c, d]) {
                        *slot = node_id(t, &mut out.mesh, &what)?;
                    }
                    out.mesh.elements.push(el);
                    out.mesh.region.push(region);
                    out.element_tags.push(e.element_tag);
                }
            }
            _ => {
                return Err(format!(
                    "{dim}-D elements ({:?}) in entity {tag}: only 2-D meshes are read",
                    block.element_type
                ));
            }
        }
    }
    if let Some(missing) = want.regions.iter().zip(&seen).find(|(_, s)| !**s) {
        return Err(format!(
            "no 2-D physical group \"{}\" with quadrilaterals: the model's materials are {:?}",
            missing.0, want.regions
        ));
    }
    // Boundary lines may only use nodes of the quadrilaterals (a node no element holds
    // would leave the stiffness singular).
    for (g, ends, tag) in line_tags {
        let mut pair = [0u32; 2];
        for (slot, t) in pair.iter_mut().zip(ends) {
            *slot = *index.get(&t).ok_or_else(|| {
                format!("line {tag} of \"{g}\" uses node {t}, which no quadrilateral uses")
            })?;
        }
        out.lines.entry(g).or_default().push((pair, tag));
    }
    for (g, needed) in [
        (TOP, true),
        (BOTTOM, want.need_bottom),
        (LUMEN, want.need_lumen),
    ] {
        if needed && out.lines.get(g).is_none_or(Vec::is_empty) {
            return Err(format!(
                "no 1-D physical group \"{g}\" with line elements: the model needs it \
                 (docs/fem.md, Gmsh meshes)"
            ));
        }
    }
    Ok(out)
}
