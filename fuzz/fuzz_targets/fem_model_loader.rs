//! The FEM model files (`config/fem/*.ron`): arbitrary text through
//! `config::load_str::<ModelFile>`, then, for an accepted model, its mesh (what
//! `pulsetrack fem` builds first; the solve is not run: seconds per model). Nothing may panic
//! and no accepted model may take more than a moment to mesh or refuse (the mesher's node
//! limit must hold before it allocates). A refusal names the origin; an accepted model
//! validates again, its materials are usable, its lumen pressure is finite at every output
//! time, and a mesh that builds has finite nodes, elements that use existing nodes with a
//! positive area, and a top and a bottom row.
#![no_main]

use config::{Validate, Validator};
use libfuzzer_sys::fuzz_target;
use pulsetrack_fem::mesher::MAX_NODES;
use pulsetrack_fem::model::ModelFile;
use pulsetrack_fem::run::build_mesh;

const ORIGIN: &str = "fuzz-fem.ron";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let model = match config::load_str::<ModelFile>(ORIGIN, text) {
        Err(e) => {
            assert_eq!(e.file, ORIGIN);
            assert!(!e.problems.is_empty());
            for line in e.to_string().lines() {
                assert!(line.starts_with(ORIGIN), "names no file: {line:?}");
            }
            return;
        }
        Ok(m) => m,
    };
    let mut v = Validator::new();
    model.validate(&mut v);
    let again = v.into_problems();
    assert!(again.is_empty(), "accepted, then: {again:?}");
    assert!(model.materials().iter().all(|m| m.is_valid()));
    for &t in &model.times_s {
        let p = model.pressure_at(t);
        assert!(p.is_finite(), "lumen pressure {p} at {t} s");
    }
    if let Some(f) = model.feature() {
        let mut r = f.lumen_radius_m.unwrap_or(0.0);
        for l in &f.layers {
            assert!(
                l.outer_radius_m.is_finite() && l.outer_radius_m > r,
                "{f:?}"
            );
            r = l.outer_radius_m;
        }
    }
    let Ok(mesh) = build_mesh(&model, 0) else {
        return;
    };
    assert!(mesh.nodes.len() <= MAX_NODES, "{} nodes", mesh.nodes.len());
    assert!(mesh.nodes.iter().flatten().all(|x| x.is_finite()));
    assert!(!mesh.top.is_empty() && !mesh.bottom.is_empty());
    assert_eq!(mesh.region.len(), mesh.elements.len());
    for (e, nodes) in mesh.elements.iter().enumerate() {
        assert!(nodes.iter().all(|&n| (n as usize) < mesh.nodes.len()));
        let a = mesh.signed_area(e);
        assert!(a > 0.0, "element {e} has area {a}");
    }
});
