//! `pulsetrack sim --events`: every stderr line is one JSON object (the tracker's events with
//! the believed and true sensor positions, then the trial's end), stdout keeps `--json`'s
//! document; `--events-text` gives lines for people.

use std::process::{Command, Output, Stdio};

fn sim(extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args([
            "sim",
            "--scene",
            "seed-arc-145",
            "--tracker",
            "beatslide",
            "--trials",
            "2",
        ])
        .args(extra)
        .stdin(Stdio::null())
        .output()
        .expect("run pt-console sim")
}

#[test]
fn events_are_json_lines_with_believed_and_true_positions() {
    let out = sim(&["--events", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let events: Vec<serde_json::Value> = stderr
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: not JSON: {l}")))
        .collect();
    let located: Vec<&serde_json::Value> =
        events.iter().filter(|e| e["kind"] == "located").collect();
    assert!(located.len() >= 4, "{stderr}");
    for e in &located {
        for key in ["believed_sensor", "true_sensor", "point", "sensor"] {
            assert!(
                e[key]["x_m"].is_f64() && e[key]["z_m"].is_f64(),
                "{key}: {e}"
            );
        }
        assert!(e["t_s"].is_f64() && e["off_artery_m"].is_f64(), "{e}");
        // Metres: the arc is some centimetres across, nowhere near metres or micrometres.
        let x = e["true_sensor"]["x_m"].as_f64().unwrap_or(f64::NAN);
        assert!(x.abs() < 0.5, "{e}");
    }
    let ends: Vec<&serde_json::Value> = events.iter().filter(|e| e["kind"] == "trial").collect();
    assert_eq!(ends.len(), 2, "{stderr}");
    assert_eq!(
        (ends[0]["trial"].as_u64(), ends[1]["trial_seed"].as_u64()),
        (Some(1), Some(2))
    );
    assert!(events.iter().all(|e| e["trial"].is_u64()), "{stderr}");
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    assert_eq!(doc["trials"].as_array().map(Vec::len), Some(2));
}

#[test]
fn events_text_is_for_people() {
    let out = sim(&["--events", "--events-text"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(" mm off the artery") && stderr.contains("located"),
        "{stderr}"
    );
    assert!(!stderr.contains("Located("), "no debug structs: {stderr}");
    let out = sim(&["--events-text"]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "--events-text needs --events: {out:?}"
    );
}
