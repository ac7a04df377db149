//! The joint stop sweep end to end: the real daemon on a bench whose arm rests unpowered in
//! its reset pose with the instrument out, joint 0's encoder 1 degree off, and joint 0's
//! lower mechanical stop 30 mrad *inside* its software limit (the upper 50 mrad outside).
//! `calibrate joints home` then `calibrate joints sweep` over the socket power the arm in
//! joint space (no rod through the pivot), find both stops of joint 0 within a few encoder
//! counts, say plainly that the lower one lies inside the limit, write them into the
//! calibration file's `joints` record, show them in `status` and load them at the next start.
//! Refused: a sweep before the homing, without `instrument_out`, with a joint that does not
//! exist. `stop` mid-sweep brings the arm back where it started, powers it off and writes
//! nothing; `disable` mid-sweep powers it off at once and writes nothing.

mod e2e;

use std::path::Path;

use e2e::{Setup, T, call, start};
use serde_json::{Value, json};

/// The scene's encoder error on joint 0, rad (1 degree).
const ZERO_ERROR_RAD: f64 = 0.017_453_3;
/// Joint 0's lower stop lies this far inside the configured limit, rad (negative: inside).
const LOWER_BEYOND_RAD: f64 = -0.03;
const UPPER_BEYOND_RAD: f64 = 0.05;
/// How close a found stop must come to the true one: the homing's residual (half a count)
/// plus the encoder's count (joint 0: 2π / (1024 · 13.3) = 0.46 mrad) and the stall's creep
/// against the capped torque; 1.5 mrad is about three counts, 0.09 degree.
const FOUND_WITHIN_RAD: f64 = 1.5e-3;

fn scene_file(dir: &Path) -> String {
    scene_with_lower_stop(dir, LOWER_BEYOND_RAD)
}

/// The bench with joint 0's lower stop `lower_beyond_rad` beyond its limit, the other stops
/// 50 mrad outside theirs.
fn scene_with_lower_stop(dir: &Path, lower_beyond_rad: f64) -> String {
    let joints = format!(
        "joints: (encoder_zero_error_rad: ({ZERO_ERROR_RAD:?}, 0.0, 0.0), \
         stop_beyond_limit_rad: (({lower_beyond_rad:?}, {UPPER_BEYOND_RAD:?}), (0.05, 0.05), (0.05, 0.05)), \
         start_at_reset: true),"
    );
    e2e::unweighted_bench_with_joints(dir, "joints-stops.ron", &joints)
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

fn sweep0() -> Value {
    json!({"procedure": "joints", "step": "sweep", "instrument_out": true, "joints": [0]})
}

fn refused(c: &mut daemon::console::client::Client, args: Value, code: &str, why: &str) {
    let r = c.request("calibrate", args.clone(), T).expect("reply");
    assert_eq!(r["error"], code, "{args}: {r}");
    e2e::assert_says(&r, "reason", why);
}

fn joints_on_file(dir: &Path) -> config::calibration_file::JointsRecord {
    config::calibration_file::load(&dir.join("calibration.ron"))
        .expect("loads")
        .expect("written")
        .value
        .joints
        .expect("a joints record")
}

#[test]
fn the_sweep_finds_a_stop_inside_the_limit_says_so_writes_it_and_loads_it_again() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &setup(dir.path()));
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    refused(&mut c, sweep0(), "refused", "calibrate joints home");
    refused(
        &mut c,
        json!({"procedure": "joints", "step": "sweep"}),
        "refused",
        "instrument_out",
    );
    refused(
        &mut c,
        json!({"procedure": "joints", "step": "sweep", "instrument_out": true, "joints": [3]}),
        "bad_argument",
        "0, 1 or 2",
    );
    refused(
        &mut c,
        json!({"procedure": "joints", "step": "home", "instrument_out": true, "joints": [0]}),
        "bad_argument",
        "belongs to the sweep",
    );
    let homed = e2e::calibrate_and_wait(&mut c, home());
    assert_eq!(homed["applied"], true, "{homed}");

    let done = e2e::calibrate_and_wait(&mut c, sweep0());
    eprintln!("sweep result: {done}");
    assert_eq!(done["phase"], "done", "{done}");
    assert_eq!(done["applied"], true, "written: {done}");
    assert_eq!(
        done["passed"], false,
        "a stop inside the limit fails: {done}"
    );
    assert_eq!(done["software_limits_narrowed"], false, "{done}");
    let stops = done["stops"].as_array().expect("stops");
    assert_eq!(stops.len(), 2, "{done}");
    for (s, side, beyond) in [
        (&stops[0], "lower", LOWER_BEYOND_RAD),
        (&stops[1], "upper", UPPER_BEYOND_RAD),
    ] {
        // The configured limit as the daemon judged against it (the sim config's default).
        let limit = e2e::num(&s["software_limit_rad"]);
        assert_eq!(s["joint"], 0, "{s}");
        assert_eq!(s["side"], side, "{s}");
        assert_eq!(s["stalled"], true, "{s}");
        let truth = limit + if side == "lower" { -beyond } else { beyond };
        assert!(
            (e2e::num(&s["margin_rad"]) - beyond).abs() < FOUND_WITHIN_RAD,
            "{s}"
        );
        let at = e2e::num(&s["at_rad"]);
        eprintln!("joint 0 {side} stop found at {at:.5} rad, truly at {truth:.5} rad");
        assert!(
            (at - truth).abs() < FOUND_WITHIN_RAD,
            "joint 0 {side}: found {at}, truly {truth}"
        );
    }
    let inside = done["stops_inside_limits"].as_array().expect("list");
    assert_eq!(inside.len(), 1, "{done}");
    assert!(
        inside[0]
            .as_str()
            .unwrap_or("")
            .contains("joint 0 lower stop"),
        "{done}"
    );
    // The arm is back and unpowered.
    assert_eq!(e2e::state(&mut c), "disabled");

    let record = joints_on_file(dir.path());
    assert_eq!(record.stops.len(), 2);
    assert!(record.passed, "the zero still passes: {record:?}");
    assert_eq!(record.stop_checks.len(), 2);
    let status = call(&mut c, "status", json!({}));
    let shown = &status["calibration"]["joints"];
    assert_eq!(shown["stops"].as_array().map(Vec::len), Some(2), "{status}");
    assert_eq!(
        shown["stops_inside_limits"].as_array().map(Vec::len),
        Some(1),
        "{status}"
    );
    daemon.stop();

    // Loaded at the next start, still saying so.
    let (daemon, mut c) = start(dir.path(), &setup(dir.path()));
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["joints"]["stops_measured_utc"],
        json!(record.stops_measured_utc),
        "{status}"
    );
    // The command line, for people: degrees, the stop inside its limit said plainly, and a
    // failing exit code for a sweep whose stops do not pass.
    let cli = |args: &[&str]| daemon.cli(args);
    let (code, out, err) = cli(&["status"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("joint stops of") && out.contains("WARNING: joint 0 lower stop"),
        "{out}"
    );
    let (code, out, err) = cli(&[
        "calibrate",
        "joints",
        "sweep",
        "--instrument-out",
        "--joint",
        "0",
    ]);
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(
        err.contains("joint 0 lower stop"),
        "progress in degrees: {err}"
    );
    assert!(
        out.contains("joint stops: joint side") && out.contains("WARNING: joint 0 lower stop"),
        "{out}"
    );
    let (code, out, err) = cli(&[
        "calibrate",
        "joints",
        "sweep",
        "--instrument-out",
        "--joint",
        "3",
    ]);
    assert_eq!(
        code,
        Some(2),
        "a joint the arm does not have is a usage error: {out}{err}"
    );
    daemon.stop();
}

#[test]
fn stop_mid_sweep_brings_the_arm_back_powers_it_off_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c, before, start_q0) = mid_sweep(dir.path());
    call(&mut c, "stop", json!({}));
    let end = e2e::wait_calibration_end(&mut c, "joints");
    assert_eq!(end["phase"], "failed", "{end}");
    e2e::assert_says(&end, "reason", "stopped");
    assert_eq!(e2e::state(&mut c), "disabled");
    let q0 = e2e::num(&call(&mut c, "status", json!({}))["arm"]["position_rad"][0]);
    assert!(
        (q0 - start_q0).abs() < 0.02,
        "joint 0 at {q0} rad, started at {start_q0} rad"
    );
    nothing_written(dir.path(), &before);
    daemon.stop();
}

/// `disable` mid-sweep powers the arm off where it is, at once, and writes nothing.
#[test]
fn disable_mid_sweep_powers_the_arm_off_at_once_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c, before, _) = mid_sweep(dir.path());
    call(&mut c, "disable", json!({}));
    let end = e2e::wait_calibration_end(&mut c, "joints");
    assert_eq!(end["phase"], "failed", "{end}");
    e2e::assert_says(&end, "reason", "disabled");
    assert_eq!(e2e::state(&mut c), "disabled");
    let s = call(&mut c, "status", json!({}));
    assert_ne!(s["arm"]["mode"], "enabled", "{s}");
    nothing_written(dir.path(), &before);
    // The next sweep waits for the arm to be put back at rest, and says so (unheld, the
    // simulated arm sags under gravity); the daemon needs no restart.
    let r = c.request("calibrate", sweep0(), T).expect("reply");
    assert_eq!(r["error"], "refused", "{r}");
    e2e::assert_says(&r, "reason", "is moving");
    daemon.stop();
}

/// The homed bench with the sweep of joint 0 well on its way to the lower stop: the daemon,
/// its client (subscribed), the calibration file's bytes before the sweep, and joint 0's
/// angle where the sweep began.
fn mid_sweep(dir: &Path) -> (e2e::Running, daemon::console::client::Client, Vec<u8>, f64) {
    let (daemon, mut c) = start(dir, &setup(dir));
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    let homed = e2e::calibrate_and_wait(&mut c, home());
    assert_eq!(homed["applied"], true, "{homed}");
    let before = std::fs::read(dir.join("calibration.ron")).expect("written");
    let start_q0 = e2e::num(&call(&mut c, "status", json!({}))["arm"]["position_rad"][0]);
    let r = call(&mut c, "calibrate", sweep0());
    assert_eq!(r["step"], "sweep", "{r}");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    loop {
        let s = call(&mut c, "status", json!({}));
        if e2e::num(&s["arm"]["position_rad"][0]) < -0.3 {
            assert_eq!(s["state"], "calibrating", "{s}");
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the sweep never moved: {s}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    (daemon, c, before, start_q0)
}

/// The calibration file as it was before the sweep, and no stops in it.
fn nothing_written(dir: &Path, before: &[u8]) {
    assert_eq!(
        std::fs::read(dir.join("calibration.ron")).expect("there"),
        before,
        "the calibration file changed"
    );
    assert!(joints_on_file(dir).stops.is_empty());
}

/// Every joint, on the stops the simulator puts 50 mrad outside each software limit: θ2 and
/// θ3 are swept against gravity with the torque cap, θ3's upper stop with θ2 raised first
/// (the coupling); all six found where they are, all pass, the arm ends where it began.
#[test]
fn a_sweep_of_every_joint_finds_all_six_stops_outside_their_limits() {
    let dir = tempfile::tempdir().expect("tmp");
    let setup = Setup {
        scene: scene_with_lower_stop(dir.path(), 0.05),
        ..Setup::default()
    };
    let (daemon, mut c) = start(dir.path(), &setup);
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    let homed = e2e::calibrate_and_wait(&mut c, home());
    assert_eq!(homed["applied"], true, "{homed}");
    let began = e2e::num(&call(&mut c, "status", json!({}))["t_s"]);
    let done = e2e::calibrate_and_wait(
        &mut c,
        json!({"procedure": "joints", "step": "sweep", "instrument_out": true}),
    );
    eprintln!(
        "the sweep of all three joints took {:.1} s (simulated)",
        e2e::num(&done["t_s"]) - began
    );
    assert_eq!(done["phase"], "done", "{done}");
    assert_eq!(done["passed"], true, "{done}");
    assert_eq!(done["applied"], true, "{done}");
    let stops = done["stops"].as_array().expect("stops");
    assert_eq!(stops.len(), 6, "{done}");
    for s in stops {
        let margin = e2e::num(&s["margin_rad"]);
        eprintln!(
            "joint {} {} stop: {:.5} rad, {margin:+.5} rad beyond its limit (truly +0.05)",
            s["joint"],
            s["side"],
            e2e::num(&s["at_rad"])
        );
        assert_eq!(s["stalled"], true, "{s}");
        assert!((margin - 0.05).abs() < FOUND_WITHIN_RAD, "{s}");
    }
    assert!(
        done["stops_inside_limits"]
            .as_array()
            .is_some_and(Vec::is_empty),
        "{done}"
    );
    daemon.stop();
}

/// "Applied means written": with no room for the file the stops are announced not applied,
/// the old file stays whole and `status` shows no stops.
#[test]
fn a_full_disk_leaves_the_file_and_the_stops_as_they_were() {
    let dir = tempfile::tempdir().expect("tmp");
    let Some((daemon, mut c, small, path)) =
        e2e::start_on_small_disk(dir.path(), &setup(dir.path()))
    else {
        return;
    };
    let homed = e2e::calibrate_and_wait(&mut c, home());
    assert_eq!(homed["applied"], true, "{homed}");
    let before = std::fs::read(&path).expect("written");
    small.fill();
    let done = e2e::calibrate_and_wait(&mut c, sweep0());
    assert_eq!(done["phase"], "done", "{done}");
    assert_eq!(done["applied"], false, "{done}");
    e2e::assert_says(&done, "reason", "No space left");
    assert_eq!(std::fs::read(&path).expect("still there"), before);
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["joints"]["stops"],
        json!([]),
        "no stops in use: {status}"
    );
    daemon.stop();
}
