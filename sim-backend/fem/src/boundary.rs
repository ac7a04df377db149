//! A model's boundary conditions on its mesh: what is held and what is prescribed.
//!
//! Supports (both papers): the bottom is held in y, one bottom node below the feature is held
//! in x (removing the rigid drift; by symmetry it carries no load). The kernel's model leaves
//! the bottom free and anchors a top node instead. A platen prescribes the top's y.

use super::mesh::Mesh;
use super::model::{Bottom, Load, ModelFile};

/// Bottom supports and the platen (if any) as (fixed, prescribed) per DOF.
pub fn supports(mesh: &Mesh, model: &ModelFile) -> (Vec<bool>, Vec<f64>) {
    let mut fixed = vec![false; mesh.dofs()];
    let mut pres = vec![0.0; mesh.dofs()];
    let held = model.bottom == Bottom::Held;
    if held {
        for &n in &mesh.bottom {
            fixed[2 * n as usize + 1] = true;
        }
    }
    // One node in x against rigid drift: below the feature, or above it if the bottom is free.
    let x0 = model.x_origin_m();
    let row = if held { &mesh.bottom } else { &mesh.top };
    if let Some(&anchor) = row.iter().min_by(|&&a, &&b| {
        let da = (mesh.nodes[a as usize][0] - x0).abs();
        let db = (mesh.nodes[b as usize][0] - x0).abs();
        da.total_cmp(&db)
    }) {
        fixed[2 * anchor as usize] = true;
    }
    if let Load::Platen { indent_m } = model.load {
        for &n in &mesh.top {
            fixed[2 * n as usize + 1] = true;
            pres[2 * n as usize + 1] = -indent_m;
        }
    }
    (fixed, pres)
}
