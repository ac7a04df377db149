//! `pulsetrack check-config FILE` on the three kinds of file its help names (daemon config,
//! scene, FEM model) and on what they refer to, through the real program.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// Exit success, and everything it printed.
fn check_config(path: &Path) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_pulsetrack"))
        .arg("check-config")
        .arg(path)
        .output()
        .expect("run pulsetrack");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("panicked"), "{text}");
    (out.status.success(), text)
}

fn passes(path: &Path) -> String {
    let (ok, text) = check_config(path);
    assert!(ok, "{} refused:\n{text}", path.display());
    text
}

fn fails(path: &Path) -> String {
    let (ok, text) = check_config(path);
    assert!(!ok, "{} passed:\n{text}", path.display());
    text
}

#[test]
fn every_shipped_config_scene_and_fem_model_passes() {
    let text = passes(&repo("config/sim.ron"));
    assert!(text.contains("scene \"seed-arc-145\""), "{text}");
    passes(&repo("config/lab.ron"));
    for dir in ["config/scenes", "config/fem"] {
        let mut n = 0;
        for entry in std::fs::read_dir(repo(dir)).expect("dir") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "ron") {
                // Were all refused: "unexpected struct name" (read as a daemon config).
                passes(&path);
                n += 1;
            }
        }
        assert!(n > 0, "no files in {dir}");
    }
}

fn config_naming_scene(dir: &Path, scene: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo("config/sim.ron"))
        .expect("sim.ron")
        .replace("\"seed-arc-145.ron\"", &format!("{scene:?}"));
    let path = dir.join("daemon.ron");
    std::fs::write(&path, text).expect("write");
    path
}

#[test]
fn a_config_whose_scene_does_not_exist_is_refused_at_its_line() {
    let dir = tempfile::tempdir().expect("tmp");
    // Was "ok": the scene was never looked at.
    let config = config_naming_scene(dir.path(), "no-such-scene.ron");
    let text = fails(&config);
    // The line the loader's locator gives for `backend.scene`: the field's own line, or its
    // section's (`backend: Sim((`, where the locator stops at the tuple variant).
    let source = std::fs::read_to_string(&config).expect("read");
    let line_of = |needle: &str| {
        source
            .lines()
            .position(|l| l.contains(needle))
            .expect("a line")
            + 1
    };
    let at = |line: usize| text.contains(&format!("{}:{line}:", config.display()));
    assert!(
        (at(line_of("no-such-scene.ron")) || at(line_of("backend:")))
            && text.contains("field `backend.scene`")
            && text.contains("no such scene file"),
        "{text}"
    );
}

#[test]
fn a_config_whose_scene_file_is_broken_names_the_scene_file_and_line() {
    let dir = tempfile::tempdir().expect("tmp");
    let scene = std::fs::read_to_string(repo("config/scenes/seed-arc-220.ron"))
        .expect("scene")
        .replacen("version: 1,", "version: 1,\n    no_such_field: 3,", 1);
    std::fs::write(dir.path().join("mine.ron"), scene).expect("write");
    let config = config_naming_scene(dir.path(), "mine.ron");
    let text = fails(&config);
    let scene_path = dir.path().join("mine.ron").display().to_string();
    let line = std::fs::read_to_string(dir.path().join("mine.ron"))
        .expect("read")
        .lines()
        .position(|l| l.contains("no_such_field"))
        .expect("the bad line")
        + 1;
    assert!(
        text.contains("backend.scene") && text.contains(&format!("{scene_path}:{line}:")),
        "{text}"
    );
    assert!(text.contains("no_such_field"), "{text}");
    // The scene file on its own: the same problem.
    let text = fails(&dir.path().join("mine.ron"));
    assert!(text.contains(&format!("{scene_path}:{line}:")), "{text}");
}

#[test]
fn a_scene_whose_fem_kernel_cannot_be_built_is_refused() {
    let dir = tempfile::tempdir().expect("tmp");
    // A shipped scene with an FEM kernel whose tube sits too near the surface to mesh.
    let text = std::fs::read_to_string(repo("config/scenes/seed-arc-220.ron")).expect("scene");
    assert!(
        text.contains("artery: ("),
        "the scene has an artery section"
    );
    let text = text.replacen(
        "artery: (",
        "artery: (\n        kernel: Fem((tissue: (e_pa: 20e3, nu: 0.45), wall: (e_pa: 100e3, nu: 0.49), refine: 9)),",
        1,
    );
    let path = dir.path().join("fem-scene.ron");
    std::fs::write(&path, text).expect("write");
    let out = fails(&path);
    assert!(
        out.contains(&path.display().to_string()) && out.contains("kernel"),
        "{out}"
    );
}

#[test]
fn a_broken_fem_model_is_refused_with_its_line_and_field() {
    let dir = tempfile::tempdir().expect("tmp");
    let text = std::fs::read_to_string(repo("config/fem/seed-001-tissue.ron"))
        .expect("model")
        .replacen("version: 1,", "version: 1,\n    bogus: 1,", 1);
    let path = dir.path().join("model.ron");
    std::fs::write(&path, text).expect("write");
    let out = fails(&path);
    assert!(
        out.contains(&format!("{}:", path.display())) && out.contains("bogus"),
        "{out}"
    );
}

#[test]
fn a_file_of_no_known_kind_is_refused() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("other.ron");
    std::fs::write(&path, "Other(version: 1)").expect("write");
    let out = fails(&path);
    assert!(out.contains(&path.display().to_string()), "{out}");
    let out = fails(&dir.path().join("missing.ron"));
    assert!(out.contains("cannot read"), "{out}");
}
