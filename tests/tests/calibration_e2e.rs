//! The tactile array's calibration end to end: the real daemon on the scene whose array has
//! gains spread by 20 %, offsets and a dead element (`sensor-errors-arc-145`), the array put
//! on the calibration bench by the simulator's hook, `calibrate tactile tare` and `load`
//! over the socket; the result judged, written, used by the next trial's tracker and by
//! replay, loaded again at the next start; a bad file refused at start; a full disk that
//! leaves the old calibration in place and in use.

mod e2e;

use std::path::Path;
use std::time::Duration;

use e2e::{Setup, T, call, seed, start, start_with_config, track_to_recording, wait_event};
use serde_json::{Value, json};

const SCENE_GAINS: [f64; 10] = [1.13, 0.84, 1.19, 0.92, 1.06, 0.81, 1.0, 1.17, 0.88, 0.97];
const SCENE_OFFSETS_N: [f64; 10] = [
    0.06, -0.04, 0.11, 0.02, -0.07, 0.03, 0.09, -0.02, 0.05, -0.1,
];
const DEAD: usize = 6;
const LOAD_N: f64 = 0.25;

fn setup() -> Setup {
    Setup {
        scene: "sensor-errors-arc-145.ron".into(),
        debug_hooks: true,
        ..Setup::default()
    }
}

/// The daemon on `setup()` with the `beatslide` tracker (the shipped sim config runs the
/// seed's).
fn start_beatslide(dir: &Path) -> (e2e::Running, daemon::console::client::Client) {
    let config = e2e::write_config(dir, &setup());
    let text = std::fs::read_to_string(&config).expect("config");
    let with = text.replace("name: \"seed2002\"", "name: \"beatslide\"");
    assert_ne!(text, with, "the shipped sim config names its tracker");
    std::fs::write(&config, with).expect("write");
    start_with_config(dir, config)
}

/// One step over the socket: the reply, then the step's result event.
fn step(c: &mut daemon::console::client::Client, args: Value) -> Value {
    let r = call(c, "calibrate", args);
    let step = r["step"].as_str().expect("step").to_string();
    wait_event(c, "the calibration's result", |e| {
        e["event"] == "calibration" && e["step"] == step.as_str() && e["phase"] != "started"
    })
}

fn place(c: &mut daemon::console::client::Client, load: Option<f64>) {
    let args = match load {
        Some(l) => json!({"action": "place_array", "on": "bench", "load_per_element_n": l}),
        None => json!({"action": "place_array", "on": "tissue"}),
    };
    call(c, "debug", args);
}

/// Tare and load on the bench, back to the tissue; the load step's result.
fn calibrate(c: &mut daemon::console::client::Client) -> Value {
    call(
        c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    place(c, Some(0.0));
    let tare = step(
        c,
        json!({"procedure": "tactile", "step": "tare", "duration_s": 3.0}),
    );
    assert_eq!(tare["phase"], "done", "{tare}");
    for (e, want) in SCENE_OFFSETS_N.iter().enumerate() {
        let got = tare["offset_n"][e].as_f64().expect("offset");
        // 300 frames of 12 mN noise: SE 0.7 mN.
        assert!(
            (got - want).abs() < 0.004,
            "element {e}: {got} against {want}"
        );
    }
    place(c, Some(LOAD_N));
    let done = step(
        c,
        json!({"procedure": "tactile", "step": "load", "load_per_element_n": LOAD_N,
            "duration_s": 3.0}),
    );
    place(c, None);
    done
}

#[test]
fn the_array_is_calibrated_through_the_daemon_and_the_trackers_read_it_so() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start_beatslide(dir.path());

    // Bad requests, each refused naming why; nothing is recorded.
    for (args, code, why) in [
        (
            json!({"procedure": "tactile", "step": "load", "load_per_element_n": LOAD_N}),
            "refused",
            "needs a tare first",
        ),
        (
            json!({"procedure": "tactile", "step": "load", "load_per_element_n": -1.0}),
            "out_of_range",
            "load_per_element_n",
        ),
        (
            json!({"procedure": "tactile", "step": "tare", "duration_s": 1e9}),
            "out_of_range",
            "duration_s",
        ),
        (
            json!({"procedure": "tactile", "step": "weigh"}),
            "bad_argument",
            "unknown tactile step",
        ),
        (
            json!({"procedure": "joints", "step": "sweep", "instrument_out": true}),
            "refused",
            "calibrate joints home",
        ),
        (json!({"procedure": 7}), "bad_argument", "must be a string"),
        (json!({}), "bad_argument", "needs `procedure`"),
    ] {
        let r = c.request("calibrate", args.clone(), T).expect("reply");
        assert_eq!(r["error"], code, "{args}: {r}");
        assert!(
            r["reason"].as_str().unwrap_or("").contains(why),
            "{args}: {r}"
        );
    }
    assert!(!dir.path().join("calibration.ron").exists());

    let done = calibrate(&mut c);
    assert_eq!(done["passed"], true, "{done}");
    assert_eq!(done["applied"], true, "{done}");
    assert_eq!(done["unusable_elements"], json!([DEAD]), "{done}");
    for (e, want) in SCENE_GAINS.iter().enumerate() {
        let el = &done["elements"][e];
        if e == DEAD {
            assert_eq!(el["status"], "dead", "{el}");
            continue;
        }
        let gain = el["gain"].as_f64().expect("gain");
        let se = el["gain_standard_error"].as_f64().expect("se");
        assert!(
            (gain - want).abs() < 4.0 * se,
            "element {e}: {gain} ± {se} against {want}"
        );
    }
    // On disk before it was announced, and in use.
    let file = config::calibration_file::load(&dir.path().join("calibration.ron"))
        .expect("loads")
        .expect("written");
    let record = file.value.tactile.expect("tactile");
    assert!(record.passed);
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["tactile"]["unusable_elements"],
        json!([DEAD]),
        "{status}"
    );

    // The next trial's tracker reads the array through it, and replay does too.
    seed(&mut c);
    let (live, ended, recording) = track_to_recording(daemon, &mut c, 0.03);
    assert!(!live.is_empty(), "nothing located after the calibration");
    // The tracker that skips what the calibration marks: within a millimetre (the shipped
    // arc without sensor errors: 0.25 mm over seven trials; docs/rig-bring-up.md).
    let sd = ended["summary"]["lateral_error_m"]["sd"]
        .as_f64()
        .unwrap_or(f64::NAN);
    assert!(sd < 0.001, "lateral SD {sd} m after calibrating: {ended}");
    assert_eq!(ended["summary"]["tracker"], "beatslide");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["replay", &recording, "--json"])
        .output()
        .expect("replay");
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or(Value::Null);
    assert_eq!(
        doc["identical_to_recorded"],
        true,
        "replay through the recorded calibration: {doc} {}",
        String::from_utf8_lossy(&out.stderr)
    );

    // The next start loads it.
    let (daemon, mut c) = start_beatslide(dir.path());
    let status = call(&mut c, "status", json!({}));
    assert_eq!(
        status["calibration"]["tactile"]["measured_utc"],
        json!(record.measured_utc),
        "{status}"
    );
    daemon.stop();

    // A calibration file that cannot be used stops the start, naming it and the field.
    let path = dir.path().join("calibration.ron");
    let text = std::fs::read_to_string(&path).expect("read");
    let broken = text.replacen("gain: ", "gain: -", 1);
    std::fs::write(&path, broken).expect("write");
    let config = e2e::write_config(dir.path(), &setup());
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(&config)
        .output()
        .expect("run");
    assert_eq!(
        out.status.code(),
        Some(2),
        "a bad calibration is a config error"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("calibration.ron") && err.contains("element 0") && err.contains("gain"),
        "{err}"
    );
}

/// Stop ends a recording; a recording whose frames stop coming fails and changes nothing.
#[test]
fn a_recording_can_be_stopped_and_never_hangs() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &setup());
    call(&mut c, "subscribe", json!({"streams": ["calibration"]}));
    call(
        &mut c,
        "calibrate",
        json!({"procedure": "tactile", "step": "tare", "duration_s": 600.0}),
    );
    let r = c.request("mark", json!({}), T).expect("reply");
    e2e::assert_says(&r, "reason", "calibration recording");
    let r = c
        .request(
            "calibrate",
            json!({"procedure": "tactile", "step": "tare"}),
            T,
        )
        .expect("reply");
    assert_eq!(r["error"], "wrong_state", "{r}");
    call(&mut c, "stop", json!({}));
    let e = wait_event(&mut c, "the stopped recording", |e| {
        e["event"] == "calibration" && e["phase"] == "failed"
    });
    assert!(
        e["reason"].as_str().unwrap_or("").contains("stopped"),
        "{e}"
    );
    // The tactile stream dies mid-recording: the recording fails within its time.
    call(
        &mut c,
        "calibrate",
        json!({"procedure": "tactile", "step": "tare", "duration_s": 2.0}),
    );
    call(
        &mut c,
        "debug",
        json!({"action": "silence_tactile", "duration_s": 3600.0}),
    );
    let e = wait_event(&mut c, "the starved recording", |e| {
        e["event"] == "calibration" && e["phase"] != "started"
    });
    assert_eq!(e["phase"], "failed", "{e}");
    assert!(e["reason"].as_str().unwrap_or("").contains("frames"), "{e}");
    assert!(!dir.path().join("calibration.ron").exists());
    daemon.stop();
}

/// "Applied means written": with no room for the new file the result is announced as not
/// applied, and the old calibration stays on disk, whole, and in use.
#[test]
fn a_full_disk_leaves_the_old_calibration_in_place_and_in_use() {
    let dir = tempfile::tempdir().expect("tmp");
    let Some((config, small, path)) =
        e2e::config_with_calibration_on_small_disk(dir.path(), &setup())
    else {
        return;
    };
    let (daemon, mut c) = start_with_config(dir.path(), config);
    let first = calibrate(&mut c);
    assert_eq!(first["applied"], true, "{first}");
    let before = std::fs::read(&path).expect("written");
    small.fill();
    let second = calibrate(&mut c);
    // Two recordings of fresh noise: their measured noise differs, which tells them apart.
    assert_ne!(first["noise_sd_n"], second["noise_sd_n"]);
    e2e::assert_passed_but_not_saved(&second, &path, &before);
    let status = call(&mut c, "status", json!({}));
    let on_disk = config::calibration_file::load(&path)
        .expect("loads")
        .expect("present")
        .value
        .tactile
        .expect("tactile");
    let in_use = status["calibration"]["tactile"]["noise_sd_n"]
        .as_f64()
        .expect("noise");
    let disk_noise = on_disk.calibration.noise_sd_n().expect("noise");
    assert!(
        (in_use - disk_noise).abs() < 1e-12 && first["noise_sd_n"].as_f64() == Some(in_use),
        "the calibration in use is the first, the one on disk: {status}"
    );
    daemon.stop();
    std::thread::sleep(Duration::from_millis(10));
}

/// `pulsetrack calibrate` waits for the result, prints it, and exits by it: 0 for a tare
/// recorded, 1 for a calibration that failed its checks (nothing applied) or a procedure not
/// built.
#[test]
fn the_command_line_prints_the_result_and_exits_by_it() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &setup());
    let cli = |args: &[&str]| daemon.cli(&[&["calibrate"], args].concat());
    place(&mut c, Some(0.0));
    let (code, out, err) = cli(&["tactile", "tare", "--duration-s", "2", "--json"]);
    assert_eq!(code, Some(0), "{out}{err}");
    let done: Value = serde_json::from_str(out.trim()).expect("one JSON line");
    assert_eq!(
        (done["step"].clone(), done["phase"].clone()),
        (json!("tare"), json!("done"))
    );
    // Nothing was put on the array: every gain is about 0, every element dead.
    let (code, out, err) = cli(&["tactile", "load", "--load-per-element-n", "0.25"]);
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(out.contains("NOT applied") && out.contains("FAIL"), "{out}");
    assert!(!dir.path().join("calibration.ron").exists());
    let (code, out, err) = cli(&["joints", "sweep", "--instrument-out"]);
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(
        err.contains("calibrate joints home"),
        "the sweep needs the homing: {err}"
    );
    daemon.stop();
}
