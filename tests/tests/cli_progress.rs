//! Long work reports progress on stderr in plain whole lines when stderr is not a terminal
//! (no cursor codes, no carriage returns), and stdout keeps `--json`'s document alone.

use std::process::{Command, Stdio};

#[test]
fn bench_in_a_pipe_gives_plain_progress_lines_and_clean_json() {
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args([
            "bench",
            "--scenes",
            "seed-arc-145",
            "--trackers",
            "beatslide",
            "--trials",
            "2",
            "--json",
        ])
        .stdin(Stdio::null())
        .output()
        .expect("run pt-console bench");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        !stderr.contains('\u{1b}') && !stderr.contains('\r'),
        "terminal codes in a pipe: {stderr:?}"
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 2, "{stderr}");
    let mut counted: Vec<&str> = lines
        .iter()
        .map(|l| l.split(':').next().unwrap_or(""))
        .collect();
    counted.sort_unstable();
    assert_eq!(counted, ["bench 1/2", "bench 2/2"], "{stderr}");
    let doc: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("stdout is one JSON document");
    assert_eq!(doc["trials"], 2);
}

#[test]
fn a_fem_study_counts_its_models_as_they_are_solved() {
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["fem", "--study", "seed-001", "--json"])
        .stdin(Stdio::null())
        .output()
        .expect("run pt-console fem");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        !stderr.contains('\u{1b}') && !stderr.contains('\r'),
        "{stderr:?}"
    );
    let mut models: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("seed-001: models solved "))
        .filter_map(|l| l.rsplit(": ").next())
        .collect();
    models.sort_unstable();
    assert_eq!(
        models,
        ["healthy-artery", "stenotic-artery", "tissue", "tumour"],
        "{stderr}"
    );
    assert!(stderr.contains("models solved 4/4"), "{stderr}");
    let doc: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("stdout is one JSON document");
    assert!(doc.as_array().is_some_and(|a| !a.is_empty()));
}
