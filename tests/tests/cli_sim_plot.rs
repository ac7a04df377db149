//! `pulsetrack sim --plot` for a tracker that never seeded: it says so, draws what it can
//! (the true artery, the trial shown as never seeded) and still prints the results.

use std::process::{Command, Stdio};

#[test]
fn a_tracker_that_never_seeded_is_said_so_and_the_results_still_print() {
    let dir = tempfile::tempdir().expect("tmp");
    let plots = dir.path().join("plots");
    let run = |json: bool| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_pt-console"));
        cmd.args([
            "sim",
            "--scene",
            "weak-pulse-3kpa.ron",
            "--tracker",
            "seed2002",
            "--plot",
        ])
        .arg(&plots)
        .stdin(Stdio::null());
        if json {
            cmd.arg("--json");
        }
        cmd.output().expect("run pt-console sim")
    };
    let out = run(true);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the results");
    let trial = &doc["trials"][0];
    assert_eq!(trial["completed"], false, "{doc}");
    assert_eq!(trial["located"].as_array().map(Vec::len), Some(0), "{doc}");
    assert!(stderr.contains("never seeded"), "{stderr}");
    assert!(stderr.contains("error_along_path not drawn"), "{stderr}");
    assert!(plots.join("top_view.svg").is_file(), "{stderr}");
    let svg = std::fs::read_to_string(plots.join("top_view.svg")).expect("svg");
    assert!(
        svg.contains("never seeded"),
        "the legend shows the trial as such"
    );
    // The human summary too.
    let out = run(false);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("not_seeded") && stdout.contains("0/1 completed"),
        "{stdout}"
    );
}

/// The ten elements' trace is band-passed as in the seed's Fig. 2 unless asked raw, and its
/// title says which.
#[test]
fn the_element_trace_is_band_passed_unless_asked_raw() {
    let dir = tempfile::tempdir().expect("tmp");
    let plot = |sub: &str, raw: bool| {
        let plots = dir.path().join(sub);
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_pt-console"));
        cmd.args([
            "sim",
            "--scene",
            "seed-radial-wrist.ron",
            "--tracker",
            "seed2002",
            "--plot",
        ])
        .arg(&plots)
        .stdin(Stdio::null());
        if raw {
            cmd.arg("--plot-raw");
        }
        let out = cmd.output().expect("run pt-console sim");
        assert_eq!(out.status.code(), Some(0), "{out:?}");
        std::fs::read_to_string(plots.join("elements_4s.svg")).expect("the trace")
    };
    let filtered = plot("filtered", false);
    assert!(filtered.contains("band-passed") && !filtered.contains("as read"));
    let raw = plot("raw", true);
    assert!(raw.contains("as read") && !raw.contains("band-passed"));
    // --plot-raw alone is a usage error: there is no plot to draw it in.
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["sim", "--scene", "seed-radial-wrist.ron", "--plot-raw"])
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(2), "{out:?}");
}
