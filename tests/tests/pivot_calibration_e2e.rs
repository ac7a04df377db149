//! The pivot's calibration end to end: the real daemon on the bench whose incision lies 5 mm
//! from where its config says (base `z`), with the added mass taken off and the instrument
//! held at the start until the arm is powered (`pivot-off-arc-145-unweighted`), `calibrate
//! pivot` over the socket touching the level foam at six points spread in `x` and `z`; the
//! fit judged, written, handed to the loop with no jump of the arm, shown in `status` and
//! loaded at the next start; a layout along one line refused naming why; `stop`
//! mid-procedure changing nothing; a full disk leaving the old pivot in use; and a tracker run
//! with the mass back on (`pivot-off-arc-145`) through the calibration measured against one
//! without it.

mod e2e;

use e2e::{Setup, T, call, start, wait_event};
use serde_json::{Value, json};

const SCENE: &str = "pivot-off-arc-145-unweighted.ron";
/// The scene's error: the true pivot against the config's, base `x` and `z`.
const TRUE_OFFSET_M: [f64; 2] = [0.0, 0.005];
/// How close the fit must come to it, each way: a tenth of the error.
const RECOVERED_WITHIN_M: f64 = 0.5e-3;
/// Points of the level foam away from the artery (over it the pulsing tube lifts the
/// surface), spread both ways.
const PLATE_M: [[f64; 2]; 6] = [
    [-0.08, 0.045],
    [0.08, 0.045],
    [-0.04, 0.01],
    [0.04, 0.01],
    [0.0, -0.065],
    [-0.1, -0.02],
];

fn setup() -> Setup {
    Setup {
        scene: SCENE.into(),
        ..Setup::default()
    }
}

fn request() -> Value {
    json!({"procedure": "pivot", "points_m": PLATE_M})
}

#[test]
fn the_pivot_is_found_by_touch_written_used_and_loaded_again() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &setup());
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    call(&mut c, "enable", json!({}));
    // Requests that cannot fix the pivot, each refused naming why; nothing moves or is
    // written.
    for (args, code, why) in [
        (
            json!({"procedure": "pivot", "points_m": [[0.0, 0.0], [0.01, 0.0], [0.0, 0.01], [0.02, 0.02]]}),
            "bad_argument",
            "5 to 16 points",
        ),
        (
            json!({"procedure": "pivot", "points_m": [[-0.08, 0.04], [-0.04, 0.041], [0.0, 0.04], [0.04, 0.041], [0.08, 0.04]]}),
            "bad_argument",
            "lie along one line",
        ),
        (
            json!({"procedure": "pivot", "points_m": [[-0.08, 0.04], [0.5, 0.0], [0.0, 0.04], [0.04, 0.0], [0.08, 0.04]]}),
            "refused",
            "point 1",
        ),
    ] {
        let r = c.request("calibrate", args.clone(), T).expect("reply");
        assert_eq!(r["error"], code, "{args}: {r}");
        e2e::assert_says(&r, "reason", why);
    }
    assert_eq!(e2e::state(&mut c), "holding");
    assert!(!dir.path().join("calibration.ron").exists());

    let done = e2e::calibrate_and_wait(&mut c, request());
    assert_eq!(done["phase"], "done", "{done}");
    assert_eq!(done["passed"], true, "{done}");
    assert_eq!(done["applied"], true, "{done}");
    for i in 0..2 {
        let error = e2e::num(&done["offset_m"][i]) - TRUE_OFFSET_M[i];
        assert!(
            error.abs() < RECOVERED_WITHIN_M,
            "offset {i} off by {error} m: {done}"
        );
    }
    assert!(e2e::num(&done["rms_residual_m"]) < 0.2e-3, "{done}");
    eprintln!(
        "pivot fit: offset {} m, standard error {} m, residual {} m",
        done["offset_m"], done["standard_error_m"], done["rms_residual_m"]
    );

    // On disk before it was announced, in the status, and the arm held where it was.
    let path = dir.path().join("calibration.ron");
    let record = config::calibration_file::load(&path)
        .expect("loads")
        .expect("written")
        .value
        .pivot
        .expect("pivot");
    assert!(record.passed);
    assert_eq!(record.touched_in_tissue_m.len(), PLATE_M.len());
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["pivot"]["measured_utc"],
        json!(record.measured_utc),
        "{status}"
    );
    assert_eq!(status["state"], "holding", "{status}");

    // `stop` mid-procedure: failed, nothing changed, holding.
    call(&mut c, "calibrate", request());
    wait_event(&mut c, "the first touch", |e| {
        e["event"] == "calibration" && e["phase"] == "touched"
    });
    call(&mut c, "stop", json!({}));
    let stopped = e2e::wait_calibration_end(&mut c, "pivot");
    assert_eq!(stopped["phase"], "failed", "{stopped}");
    e2e::assert_says(&stopped, "reason", "stopped");
    e2e::wait_state(&mut c, "holding");
    let after = config::calibration_file::load(&path)
        .expect("loads")
        .expect("there")
        .value
        .pivot
        .expect("pivot");
    assert_eq!(after, record, "a stopped procedure changed the file");
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["pivot"]["measured_utc"],
        json!(record.measured_utc),
        "{status}"
    );
    daemon.stop();

    // The next start loads it; the command line's status says it for people, in mm.
    let (daemon, mut c) = start(dir.path(), &setup());
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["pivot"]["pivot_in_base_m"],
        json!(record.pivot_in_base_m),
        "{status}"
    );
    let (_, said, _) = daemon.cli(&["status"]);
    let moved_z_mm = format!("z {:+.2} mm", record.offset_m[1] * 1e3);
    assert!(
        said.contains(&format!("calibrated pivot of {}", record.measured_utc))
            && said.contains(&moved_z_mm),
        "{said}"
    );
    daemon.stop();

    // A record that failed its checks stops the start, naming the file.
    let config = e2e::write_config(dir.path(), &setup());
    e2e::failed_record_stops_the_start(
        &config,
        &path,
        |f| {
            if let Some(p) = f.pivot.as_mut() {
                p.passed = false;
            }
        },
        "its pivot",
    );

    // A tracker run through the calibration against one without it (the lockstep runner,
    // seeds 1 and 2, the mass back on): the wrong pivot puts every reported point to one
    // side of the artery.
    let sim = |extra: &[&str]| e2e::sim_two_trials("pivot-off-arc-145", extra);
    let worst_mean = |doc: &Value| -> f64 {
        doc["trials"]
            .as_array()
            .expect("trials")
            .iter()
            .map(|t| e2e::num(&t["lateral_error_m"]["mean"]).abs())
            .fold(0.0, f64::max)
    };
    let without = sim(&[]);
    let with = sim(&["--calibration", &path.display().to_string()]);
    let (off_without, off_with) = (worst_mean(&without), worst_mean(&with));
    eprintln!("mean lateral error: without {off_without} m, calibrated {off_with} m");
    assert!(
        off_with < 1e-3,
        "calibrated: mean lateral error {off_with} m"
    );
    assert!(
        off_without > 5.0 * off_with,
        "uncalibrated {off_without} m against calibrated {off_with} m"
    );
}

/// "Applied means written": with no room for the new file the pivot is announced as not
/// applied, the old file stays whole and the old pivot stays in use.
#[test]
fn a_full_disk_leaves_the_old_pivot_in_place_and_in_use() {
    let dir = tempfile::tempdir().expect("tmp");
    let Some((daemon, mut c, small, path)) = e2e::start_on_small_disk(dir.path(), &setup()) else {
        return;
    };
    call(&mut c, "enable", json!({}));
    let first = e2e::calibrate_and_wait(&mut c, request());
    assert_eq!(first["applied"], true, "{first}");
    let before = std::fs::read(&path).expect("written");
    small.fill();
    let second = e2e::calibrate_and_wait(&mut c, request());
    e2e::assert_passed_but_not_saved(&second, &path, &before);
    let on_disk = config::calibration_file::load(&path)
        .expect("loads")
        .expect("present")
        .value
        .pivot
        .expect("pivot");
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["pivot"]["measured_utc"],
        json!(on_disk.measured_utc),
        "the pivot in use is the one on disk: {status}"
    );
    daemon.stop();
}

/// A tissue frame measured through the wrong pivot (from a file written before tissue
/// records named their pivot, as the configured frame): once the pivot is calibrated, the
/// frame is said to be stale (in the pivot's result and `status`), a trial or a search is
/// refused naming what to do, and measuring the frame again through the new pivot lifts
/// that. (Measured through this scene's 5 mm pivot error the plate reads 2.4 degrees
/// tilted and the tissue procedure refuses it; the old frame stands for one that passed.)
#[test]
fn a_pivot_calibrated_after_the_tissue_frame_makes_it_stale_until_measured_again() {
    let dir = tempfile::tempdir().expect("tmp");
    let configured = json!({"origin_in_base_m": [0.0, -0.3745, 0.055], "yaw_rad": 0.0});
    let old = config::calibration_file::CalibrationFile {
        tissue: Some(config::calibration_file::TissueRecord {
            measured_utc: "2026-01-05T09-00-00Z".into(),
            surface_in_base_m: vec![
                [-0.08, -0.3745, 0.1],
                [0.08, -0.3745, 0.1],
                [0.0, -0.3745, 0.06],
            ],
            course_in_base_m: None,
            course_lateral_m: 0.0,
            prior: serde_json::from_value(configured.clone()).expect("a placement"),
            placement: serde_json::from_value(configured).expect("a placement"),
            tilt_rad: 0.0,
            pivot_in_base_m: None,
            joint_zero_rad: None,
            rms_residual_m: 0.0,
            max_residual_m: 0.0,
            checks: vec![],
            passed: true,
        }),
        ..Default::default()
    };
    config::calibration_file::save(&dir.path().join("calibration.ron"), &old).expect("saved");
    let (daemon, mut c) = start(dir.path(), &setup());
    call(&mut c, "subscribe", json!({"streams": ["calibration"]}));
    call(&mut c, "enable", json!({}));
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["tissue"]["stale"],
        Value::Null,
        "{status}"
    );

    let pivot = e2e::calibrate_and_wait(&mut c, request());
    assert_eq!(pivot["applied"], true, "{pivot}");
    e2e::assert_says(&pivot, "tissue_stale", "calibrate tissue");
    let status = call(&mut c, "status", json!({}));
    e2e::assert_says(
        &status["calibration"]["tissue"],
        "stale",
        "before the pivot calibration",
    );
    for (verb, args) in [
        ("mark", json!({})),
        (
            "search",
            json!({"x0_m": -0.02, "z0_m": -0.02, "x1_m": 0.02, "z1_m": 0.02}),
        ),
    ] {
        let r = c.request(verb, args, T).expect("reply");
        assert_eq!(r["error"], "wrong_state", "{verb}: {r}");
        e2e::assert_says(&r, "reason", "calibrate tissue");
    }
    // The human status says it too.
    let (_, said, _) = daemon.cli(&["status"]);
    assert!(said.contains("WARNING: the tissue frame"), "{said}");

    // Measured again through the calibrated pivot the plate reads level and the frame
    // passes; it names that pivot, and is true again.
    let again = e2e::calibrate_and_wait(
        &mut c,
        json!({"procedure": "tissue", "points_m": PLATE_M[..5]}),
    );
    assert_eq!(again["applied"], true, "{again}");
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["tissue"]["stale"],
        Value::Null,
        "{status}"
    );
    let r = c.request("mark", json!({}), T).expect("reply");
    assert_ne!(r["error"], "wrong_state", "{r}");
    daemon.stop();
}

/// A pivot off along the course (base `x`) and back across it at once: the same procedure
/// finds both components (the shipped bench's error is across the course only).
#[test]
fn a_pivot_off_along_and_across_the_course_is_found_both_ways() {
    const OFFSET_M: [f64; 2] = [0.004, -0.003];
    let dir = tempfile::tempdir().expect("tmp");
    let shipped = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../config/scenes")
            .join(SCENE),
    )
    .expect("shipped scene");
    let moved = shipped.replace(
        "offset_m: (0.0, 0.0, 0.005),",
        &format!("offset_m: ({:?}, 0.0, {:?}),", OFFSET_M[0], OFFSET_M[1]),
    );
    assert_ne!(moved, shipped, "the scene's pivot offset line changed");
    let scene = dir.path().join("pivot-off-diagonal.ron");
    std::fs::write(&scene, moved).expect("write scene");
    let (daemon, mut c) = start(
        dir.path(),
        &Setup {
            scene: scene.display().to_string(),
            ..Setup::default()
        },
    );
    call(&mut c, "subscribe", json!({"streams": ["calibration"]}));
    call(&mut c, "enable", json!({}));
    let done = e2e::calibrate_and_wait(&mut c, request());
    assert_eq!(done["applied"], true, "{done}");
    for i in 0..2 {
        let error = e2e::num(&done["offset_m"][i]) - OFFSET_M[i];
        assert!(
            error.abs() < RECOVERED_WITHIN_M,
            "offset {i} off by {error} m: {done}"
        );
    }
    eprintln!(
        "pivot fit (diagonal): offset {} m, standard error {} m, residual {} m",
        done["offset_m"], done["standard_error_m"], done["rms_residual_m"]
    );
    daemon.stop();
}
