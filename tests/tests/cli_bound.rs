//! `pulsetrack bound` as a user runs it: the JSON fields other tools read, and bad input
//! refused with a message naming what was wrong.

use std::process::Command;

fn bound(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .arg("bound")
        .args(args)
        .output()
        .expect("run pt-console bound")
}

#[test]
fn the_bound_of_a_weak_pulse_is_printed_as_json() {
    let out = bound(&["--scene", "weak-pulse-3kpa.ron", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "stderr: {stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON document");
    assert_eq!(v["scene"], "weak-pulse-3kpa");
    let centre = &v["positions"][0];
    assert_eq!(centre["offset_m"], 0.0);
    let known = centre["beats_known_position"].as_f64().expect("beats");
    let searched = centre["beats_unknown_position"].as_f64().expect("beats");
    let sd = centre["position_sd_m"].as_f64().expect("metres");
    // A tenth of the noise per element per sample: several beats, more when searched.
    assert!(known > 3.0 && searched > known, "{known} {searched}");
    assert!(sd > 0.0 && sd < 0.002, "{sd}");
}

#[test]
fn bad_options_and_scenes_are_named() {
    let out = bound(&["--scene", "weak-pulse-3kpa.ron", "--pfa", "1.5"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr.contains("false-alarm rate") && stderr.contains("1.5"),
        "{stderr}"
    );
    let out = bound(&["--scene", "no-such-scene.ron"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr.contains("no-such-scene"), "{stderr}");
    assert!(!stderr.contains("panicked"));
}
