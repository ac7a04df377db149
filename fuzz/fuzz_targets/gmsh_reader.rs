//! Gmsh meshes (`pulsetrack fem --mesh FILE.msh`, a model's `mesh_file`): arbitrary bytes
//! through `pulsetrack_fem::gmsh::parse_mesh` (the header and section guards, the physical
//! names, mshio's ASCII and binary MSH 4.1 reader, the build and the geometric checks), once
//! for a model with an artery (tissue and wall, a lumen, the bottom held) and once for plain
//! tissue (no lumen), both on the seed-001 block (0.08 m x 0.03 m). Nothing may panic. A
//! refusal names the file and says what is wrong; an accepted mesh has at most `MAX_NODES`
//! finite nodes, elements on existing nodes with a positive area and a region the model
//! names, a top row spanning the block's width, a bottom row when the model holds it, and
//! lumen edges on existing nodes with a finite centre when the model has a lumen.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pulsetrack_fem::gmsh::{Expected, parse_mesh};
use pulsetrack_fem::mesh::Mesh;
use pulsetrack_fem::mesher::MAX_NODES;

const ORIGIN: &str = "fuzz.msh";

fn artery() -> Expected {
    Expected {
        regions: vec!["tissue".into(), "wall".into()],
        need_bottom: true,
        need_lumen: true,
        width_m: 0.08,
        height_m: 0.03,
    }
}

fn tissue_only() -> Expected {
    Expected {
        regions: vec!["tissue".into()],
        need_bottom: false,
        need_lumen: false,
        ..artery()
    }
}

fn check(mesh: &Mesh, want: &Expected) {
    let n = mesh.nodes.len();
    assert!(n <= MAX_NODES, "{n} nodes");
    assert!(mesh.nodes.iter().flatten().all(|x| x.is_finite()));
    assert_eq!(mesh.region.len(), mesh.elements.len());
    for (e, nodes) in mesh.elements.iter().enumerate() {
        assert!(nodes.iter().all(|&k| (k as usize) < n), "element {e}");
        let a = mesh.signed_area(e);
        assert!(a > 0.0, "element {e} has area {a}");
        assert!(
            usize::from(mesh.region[e]) < want.regions.len(),
            "element {e} in region {}",
            mesh.region[e]
        );
    }
    assert!(mesh.top.iter().all(|&k| (k as usize) < n));
    let tol = 1e-6 * want.width_m.max(want.height_m);
    let x = |k: &u32| mesh.nodes[*k as usize][0];
    assert!(
        mesh.top.first().map(x).is_some_and(|x0| x0 <= tol)
            && mesh
                .top
                .last()
                .map(x)
                .is_some_and(|x1| x1 >= want.width_m - tol),
        "the top row does not span the block"
    );
    if want.need_bottom {
        assert!(!mesh.bottom.is_empty(), "no bottom row");
    }
    assert!(mesh.bottom.iter().all(|&k| (k as usize) < n));
    assert!(mesh.lumen_edges.iter().flatten().all(|&k| (k as usize) < n));
    if want.need_lumen {
        let c = mesh.feature_centre.expect("a lumen has a centre");
        assert!(c.iter().all(|x| x.is_finite()), "lumen centre {c:?}");
    }
}

fuzz_target!(|data: &[u8]| {
    for want in [artery(), tissue_only()] {
        match parse_mesh(ORIGIN, data, &want) {
            Err(e) => {
                assert_eq!(e.file, ORIGIN);
                assert!(!e.problem.trim().is_empty(), "an empty reason");
                assert!(e.to_string().starts_with(ORIGIN), "{e}");
            }
            Ok(mesh) => check(&mesh, &want),
        }
    }
});
