//! `pulsetrack fem --model M --mesh FILE.msh` and a model's `mesh_file` through
//! `check-config` (docs/fem.md, Gmsh meshes): the mesh is solved, and a bad one is an error
//! naming the file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace")
        .to_path_buf()
}

fn model() -> String {
    root()
        .join("config/fem/seed-001-healthy-artery.ron")
        .display()
        .to_string()
}

fn mesh(name: &str) -> String {
    root()
        .join("sim-backend/fem/tests/data")
        .join(name)
        .display()
        .to_string()
}

fn pulsetrack(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("run pt-console")
}

fn records(out: &Output) -> Vec<serde_json::Value> {
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON array");
    doc.as_array().expect("an array").clone()
}

#[test]
fn fem_solves_a_model_on_a_gmsh_mesh() {
    let (model, msh) = (model(), mesh("seed-001-healthy-artery.msh"));
    let gmsh = records(&pulsetrack(&[
        "fem", "--model", &model, "--mesh", &msh, "--json",
    ]));
    let built_in = records(&pulsetrack(&["fem", "--model", &model, "--json"]));
    assert_eq!(gmsh.len(), 4);
    assert_eq!(gmsh[0]["model"], "healthy-artery");
    // The Gmsh mesh's 1 908 nodes, not the built-in 2 368.
    assert_eq!(gmsh[0]["dofs"], 3816);
    assert_eq!(built_in[0]["dofs"], 4736);
    for (g, b) in gmsh.iter().zip(&built_in) {
        let (g, b) = (
            g["peak_pa"].as_f64().expect("peak"),
            b["peak_pa"].as_f64().expect("peak"),
        );
        assert!((g - b).abs() < 0.02 * b, "peak {g} against {b}");
    }
}

#[test]
fn fem_names_a_bad_mesh_file_and_its_problem() {
    let (model, tri) = (model(), mesh("triangles.msh"));
    let out = pulsetrack(&["fem", "--model", &model, "--mesh", &tri]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("triangles.msh") && stderr.contains("quadrilaterals"),
        "{stderr}"
    );
    let out = pulsetrack(&["fem", "--model", &model, "--mesh", "no-such.msh", "--json"]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(out.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no-such.msh: cannot open"), "{stderr}");
    // A Gmsh mesh is not refined, and --mesh needs a model.
    let msh = mesh("seed-001-healthy-artery.msh");
    let out = pulsetrack(&["fem", "--model", &model, "--mesh", &msh, "--refine", "1"]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("--refine"));
    let out = pulsetrack(&["fem", "--study", "seed-001", "--mesh", &msh]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
}

#[test]
fn check_config_reads_the_mesh_a_model_names() {
    let dir = tempfile::tempdir().expect("tmp");
    let text = std::fs::read_to_string(model()).expect("read the model");
    let with =
        |file: &str| text.replace("times_s:", &format!("mesh_file: {file:?},\n    times_s:"));
    std::fs::copy(
        mesh("small-artery-binary.msh"),
        dir.path().join("artery.msh"),
    )
    .expect("copy");
    let good = dir.path().join("good.ron");
    std::fs::write(&good, with("artery.msh")).expect("write");
    let out = pulsetrack(&["check-config", good.to_str().expect("UTF-8")]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");

    std::fs::copy(mesh("triangles.msh"), dir.path().join("tri.msh")).expect("copy");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, with("tri.msh")).expect("write");
    let out = pulsetrack(&["check-config", bad.to_str().expect("UTF-8")]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("mesh_file") && stderr.contains("tri.msh") && stderr.contains("triangles"),
        "{stderr}"
    );
}
