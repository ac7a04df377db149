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

fn centre_beats(args: &[&str]) -> (f64, f64, f64) {
    let mut all = vec!["--scene", "weak-pulse-3kpa.ron", "--json"];
    all.extend_from_slice(args);
    let out = bound(&all);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON document");
    let centre = &v["positions"][0];
    (
        centre["beats_to_snr_8"].as_f64().expect("beats"),
        v["noise_sd_n"].as_f64().expect("newtons"),
        v["element_length_m"].as_f64().expect("metres"),
    )
}

#[test]
fn quieter_and_longer_elements_are_asked_for_at_the_command_line() {
    let (base, noise, length) = centre_beats(&[]);
    assert!((length - 0.002).abs() < 1e-9, "{length}");
    // Half the scene's noise: a quarter of the beats.
    let half = format!("{}", noise / 2.0);
    let (quiet, n, _) = centre_beats(&["--noise-n", &half]);
    assert!((n - noise / 2.0).abs() < 1e-12);
    assert!((base / quiet - 4.0).abs() < 0.05, "{base} {quiet}");
    // Elements 4 mm along the artery (SI in the JSON): nearly twice the force on each
    // (the scene's artery crosses the line obliquely at its first placement, so a longer
    // element gains a little less than in proportion: 3.6x fewer beats, not 4x).
    let (long, _, l) = centre_beats(&["--element-length-mm", "4"]);
    assert!((l - 0.004).abs() < 1e-9, "{l}");
    assert!(base / long > 3.0 && base / long < 3.9, "{base} {long}");
}

#[test]
fn bad_sensor_overrides_are_named() {
    for (flag, value) in [
        ("--noise-n", "0"),
        ("--noise-n", "-0.01"),
        ("--noise-n", "NaN"),
        ("--element-length-mm", "0"),
        ("--element-length-mm", "-2"),
        ("--element-length-mm", "50"),
        ("--element-length-mm", "inf"),
    ] {
        let out = bound(&["--scene", "weak-pulse-3kpa.ron", flag, value]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {stderr}");
        assert!(stderr.contains(flag), "{flag} {value}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // Not a number at all: clap names the flag.
    let out = bound(&["--scene", "weak-pulse-3kpa.ron", "--noise-n", "quiet"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--noise-n"), "{stderr}");
}
