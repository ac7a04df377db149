//! The joints' homing end to end: the real daemon on a bench whose encoders were powered up
//! 2 degrees off on joint 1 (a zero error the config does not know), the unpowered arm
//! resting in its reset pose with the instrument out of the incision; `calibrate joints home`
//! over the socket recovers the offset, writes it, hands it to the loop (the angles then read
//! the reset pose), shows it in `status` and loads it at the next start. Refused: without the
//! `instrument_out` acknowledgement, and the stop sweep before a homing. A record
//! that did not pass stops the start naming the file; a full disk leaves the old zero in use.

mod e2e;

use std::path::Path;

use e2e::{Setup, T, call, start};
use serde_json::{Value, json};

/// The scene's error: the encoders read joint 1 this much more than it truly is.
const ZERO_ERROR_RAD: [f64; 3] = [0.0, 0.0349066, 0.0];
/// How close the recovered offset must come to it: a few encoder counts (the sim's joint 1
/// has 2π / (1024 · 11.2) = 0.55 mrad per count), a fiftieth of the error.
const RECOVERED_WITHIN_RAD: f64 = 0.7e-3;

/// The pivot procedure's unweighted bench, its arm starting in the reset pose with the
/// instrument out and the encoders carrying the error.
fn scene_file(dir: &Path) -> String {
    let joints = format!(
        "joints: (encoder_zero_error_rad: ({:?}, {:?}, {:?}), start_at_reset: true),",
        ZERO_ERROR_RAD[0], ZERO_ERROR_RAD[1], ZERO_ERROR_RAD[2]
    );
    e2e::unweighted_bench_with_joints(dir, "joints-error.ron", &joints)
}

fn setup(dir: &Path) -> Setup {
    Setup {
        scene: scene_file(dir),
        ..Setup::default()
    }
}

fn home() -> Value {
    json!({"procedure": "joints", "step": "home", "instrument_out": true})
}

fn position(c: &mut daemon::console::client::Client) -> [f64; 3] {
    let s = call(c, "status", json!({}));
    [0, 1, 2].map(|j| e2e::num(&s["arm"]["position_rad"][j]))
}

#[test]
fn the_encoder_zero_is_measured_written_used_and_loaded_again() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &setup(dir.path()));
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    let before = position(&mut c);
    assert!(
        (before[1] - ZERO_ERROR_RAD[1]).abs() < RECOVERED_WITHIN_RAD,
        "uncalibrated, joint 1 reads the error: {before:?}"
    );
    for (args, code, why) in [
        (
            json!({"procedure": "joints", "step": "home"}),
            "refused",
            "instrument_out",
        ),
        (
            json!({"procedure": "joints", "step": "home", "instrument_out": "yes"}),
            "bad_argument",
            "true or false",
        ),
        (
            json!({"procedure": "joints", "step": "sweep", "instrument_out": true}),
            "refused",
            "calibrate joints home",
        ),
        (
            json!({"procedure": "joints", "step": "spin", "instrument_out": true}),
            "bad_argument",
            "unknown joints step",
        ),
    ] {
        let r = c.request("calibrate", args.clone(), T).expect("reply");
        assert_eq!(r["error"], code, "{args}: {r}");
        e2e::assert_says(&r, "reason", why);
    }
    assert!(!dir.path().join("calibration.ron").exists());

    let done = e2e::calibrate_and_wait(&mut c, home());
    assert_eq!(done["phase"], "done", "{done}");
    assert_eq!(done["passed"], true, "{done}");
    assert_eq!(done["applied"], true, "{done}");
    let offset = [0, 1, 2].map(|j| e2e::num(&done["zero_offset_rad"][j]));
    eprintln!("recovered zero offsets {offset:?} rad against the scene's {ZERO_ERROR_RAD:?}");
    for j in 0..3 {
        assert!(
            (offset[j] + ZERO_ERROR_RAD[j]).abs() < RECOVERED_WITHIN_RAD,
            "joint {j}: offset {} rad, the error {} rad",
            offset[j],
            ZERO_ERROR_RAD[j]
        );
    }
    // In use: the angles read the reset pose now.
    let after = position(&mut c);
    assert!(
        after.iter().all(|q| q.abs() < RECOVERED_WITHIN_RAD),
        "{after:?}"
    );
    let status = call(&mut c, "status", json!({}));
    let record = config::calibration_file::load(&dir.path().join("calibration.ron"))
        .expect("loads")
        .expect("written")
        .value
        .joints
        .expect("a joints record");
    assert_eq!(
        status["calibration"]["joints"]["measured_utc"],
        json!(record.measured_utc),
        "{status}"
    );
    daemon.stop();

    // Loaded at the next start: the angles read the reset pose from the first cycle.
    let (daemon, mut c) = start(dir.path(), &setup(dir.path()));
    let again = position(&mut c);
    assert!(
        again.iter().all(|q| q.abs() < RECOVERED_WITHIN_RAD),
        "{again:?}"
    );
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["joints"]["measured_utc"],
        json!(record.measured_utc),
        "{status}"
    );
    daemon.stop();

    // A record that did not pass stops the start, naming the file.
    let path = dir.path().join("calibration.ron");
    let config = e2e::write_config(dir.path(), &setup(dir.path()));
    e2e::failed_record_stops_the_start(
        &config,
        &path,
        |f| {
            if let Some(j) = f.joints.as_mut() {
                j.passed = false;
            }
        },
        "joints calibration",
    );

    // A tracker run through the homing against one without it (the lockstep runner, seeds
    // 1 and 2): the shipped 145 mm arc with the same encoder error, the mass on.
    let shipped = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/seed-arc-145.ron"),
    )
    .expect("shipped scene");
    let end = shipped.rfind(')').expect("the scene's closing bracket");
    let scene = dir.path().join("arc-145-encoder-error.ron");
    std::fs::write(
        &scene,
        format!(
            "{}    joints: (encoder_zero_error_rad: ({:?}, {:?}, {:?})),\n{}",
            &shipped[..end],
            ZERO_ERROR_RAD[0],
            ZERO_ERROR_RAD[1],
            ZERO_ERROR_RAD[2],
            &shipped[end..]
        ),
    )
    .expect("write scene");
    let scene = scene.display().to_string();
    let worst = |doc: &Value| -> (f64, usize) {
        let trials = doc["trials"].as_array().expect("trials");
        let mean = trials
            .iter()
            .map(|t| e2e::num(&t["lateral_error_m"]["mean"]).abs())
            .fold(0.0, f64::max);
        let done = trials.iter().filter(|t| t["completed"] == true).count();
        (mean, done)
    };
    let (off_without, done_without) = worst(&e2e::sim_two_trials(&scene, &[]));
    let (off_with, done_with) = worst(&e2e::sim_two_trials(
        &scene,
        &["--calibration", &path.display().to_string()],
    ));
    eprintln!(
        "encoder error: worst mean lateral error {off_without} m ({done_without} of 2 completed) without, {off_with} m ({done_with} of 2) homed"
    );
    assert!(
        off_with < 1e-3 && done_with == 2,
        "homed: {off_with} m, {done_with} of 2"
    );
    assert!(
        off_without > 3.0 * off_with || done_without < 2,
        "without: {off_without} m, {done_without} of 2"
    );
}

/// "Applied means written": with no room for the new file the zero is announced as not
/// applied, the old file stays whole and the old zero stays in use.
#[test]
fn a_full_disk_leaves_the_old_zero_in_place_and_in_use() {
    let dir = tempfile::tempdir().expect("tmp");
    let Some((daemon, mut c, small, path)) =
        e2e::start_on_small_disk(dir.path(), &setup(dir.path()))
    else {
        return;
    };
    let first = e2e::calibrate_and_wait(&mut c, home());
    assert_eq!(first["applied"], true, "{first}");
    let before = std::fs::read(&path).expect("written");
    small.fill();
    let second = e2e::calibrate_and_wait(&mut c, home());
    e2e::assert_passed_but_not_saved(&second, &path, &before);
    let status = call(&mut c, "status", json!({}));
    let on_disk = config::calibration_file::load(&path)
        .expect("loads")
        .expect("present")
        .value
        .joints
        .expect("joints");
    assert_eq!(
        status["calibration"]["joints"]["measured_utc"],
        json!(on_disk.measured_utc),
        "the zero in use is the one on disk: {status}"
    );
    daemon.stop();
}
