//! End to end: the real daemon (`pulsetrackd`, built here as `pt-daemon`) on the simulated
//! bench, driven over its Unix socket. Time runs on the simulator's clock at `time_scale`
//! times real time, so nothing here waits out real seconds of tracking.

mod e2e;

use std::path::PathBuf;
use std::time::Duration;

use daemon::recording::recover;
use daemon::recording::topics::Topic;
use e2e::{Setup, T, call, seed, start, state, wait_event};
use serde_json::{Value, json};

#[test]
fn verbs_in_the_wrong_state_are_refused_and_bad_lines_get_errors() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    assert_eq!(c.hello["hello"], "pulsetrackd");
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(&daemon.socket)
        .expect("socket")
        .permissions()
        .mode();
    assert_eq!(mode & 0o777, 0o660, "socket mode {mode:o}");
    assert_eq!(c.hello["protocol"], 1);
    for (verb, args, why) in [
        (
            "track",
            json!({}),
            "cannot track while disabled: enable first",
        ),
        (
            "mark",
            json!({}),
            "cannot mark while disabled: enable first",
        ),
        ("resume", json!({}), "nothing is paused"),
        ("reset", json!({}), "no fault is latched"),
        (
            "debug",
            json!({"action": "silence_tactile", "duration_s": 1.0}),
            "debug hooks are off",
        ),
    ] {
        let r = c.request(verb, args, T).expect("reply");
        assert_eq!(
            (r["ok"].clone(), r["error"].clone()),
            (json!(false), json!("wrong_state")),
            "{r}"
        );
        assert!(
            r["reason"].as_str().unwrap_or("").contains(why),
            "{verb}: {r}"
        );
    }
    call(&mut c, "enable", json!({}));
    let r = c.request("track", json!({}), T).expect("reply");
    e2e::assert_says(&r, "reason", "needs 2 marked seed points; have 0");
    let r = c.request("resume", json!({}), T).expect("reply");
    assert_eq!(r["state"], "holding");

    // Bad lines of every kind: an error each, and the daemon carries on.
    c.send_raw(b"{\"id\": 5, \"verb\": \n").expect("send");
    let r = c.reply_to(None, T).expect("reply");
    assert_eq!(r["error"], "malformed", "{r}");
    let mut long = vec![b'a'; 100_000];
    long.push(b'\n');
    c.send_raw(&long).expect("send");
    let r = c.reply_to(None, T).expect("reply");
    assert_eq!(r["error"], "line_too_long", "{r}");
    let r = c.request("teleport", json!({}), T).expect("reply");
    assert_eq!(r["error"], "unknown_verb", "{r}");
    let r = c
        .request("move", json!({"x_m": 1e300, "z_m": 0.0}), T)
        .expect("reply");
    assert_eq!(r["error"], "out_of_range", "{r}");
    let r = c.request("jog", json!({"dx_m": 0.5}), T).expect("reply");
    assert_eq!(r["error"], "out_of_range", "{r}");
    let st = call(&mut c, "status", json!({}));
    assert_eq!(st["state"], "holding");
    assert!(st["fault"].is_null());
    daemon.stop();
}

#[test]
fn a_stale_tactile_stream_faults_and_recovers_only_by_reset() {
    let dir = tempfile::tempdir().expect("tmp");
    let setup = Setup {
        debug_hooks: true,
        ..Setup::default()
    };
    let (daemon, mut c) = start(dir.path(), &setup);
    call(&mut c, "subscribe", json!({"streams": ["faults", "state"]}));
    call(&mut c, "enable", json!({}));
    // The documented test hook: the loop drops tactile frames for 0.5 s of simulated time.
    call(
        &mut c,
        "debug",
        json!({"action": "silence_tactile", "duration_s": 0.5}),
    );
    let f = wait_event(&mut c, "the fault", |e| e["event"] == "fault");
    assert_eq!(f["fault"], "tactile_stale", "{f}");
    assert!(f["value"].as_f64().expect("age") > f["limit"].as_f64().expect("limit"));
    let dump = PathBuf::from(f["flight_recorder"].as_str().expect("dump"));
    // The flight recorder holds the cycles that led up to it: the stream going quiet.
    let cycles: Vec<Value> = std::fs::read_to_string(&dump)
        .expect("dump")
        .lines()
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect();
    assert!(cycles.len() >= 100, "{} cycles", cycles.len());
    let last = cycles.last().expect("a cycle");
    assert!(last["tactile_age_s"].as_f64().expect("age") > 0.1, "{last}");
    // Frames flow again after the silence (simulated time; however slowly this machine
    // runs it), but the fault stays latched.
    let deadline = std::time::Instant::now() + T;
    let st = loop {
        let st = call(&mut c, "status", json!({}));
        if st["tactile"]["age_s"].as_f64().expect("age") < 0.1 {
            break st;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the stream never came back: {st}"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(st["state"], "fault");
    for verb in ["enable", "mark", "move"] {
        let r = c
            .request(verb, json!({"x_m": 0.0, "z_m": 0.0}), T)
            .expect("reply");
        assert_eq!(r["ok"], false, "{verb}: {r}");
    }
    call(&mut c, "reset", json!({}));
    assert_eq!(state(&mut c), "disabled");
    call(&mut c, "enable", json!({}));
    assert_eq!(state(&mut c), "holding");
    daemon.stop();
}

/// Messages of the recording of the one trial in `dir/trials`.
fn trial_recording(dir: &std::path::Path) -> PathBuf {
    let trials = dir.join("trials");
    let mut found: Vec<PathBuf> = std::fs::read_dir(&trials)
        .expect("trials dir")
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            let n = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            n.ends_with(".mcap") && !n.ends_with(".truncated.mcap")
        })
        .collect();
    assert_eq!(found.len(), 1, "{found:?}");
    found.remove(0)
}

#[test]
fn kill_9_mid_trial_leaves_a_readable_recording_with_everything_acknowledged() {
    let dir = tempfile::tempdir().expect("tmp");
    let (mut daemon, mut c) = start(dir.path(), &Setup::default());
    seed(&mut c);
    call(&mut c, "track", json!({}));
    // Acknowledged: the two seeds and two tracked points.
    let mut acknowledged: Vec<Value> = Vec::new();
    while acknowledged.len() < 2 {
        let e = wait_event(&mut c, "a located point", |e| {
            e["event"] == "detection" && e["kind"] == "located"
        });
        acknowledged.push(e["point"].clone());
    }
    daemon.signal(9);
    let status = daemon.wait(T);
    assert!(!status.success());
    let path = trial_recording(dir.path());
    let back = recover::read(&path).expect("a killed recording is readable");
    assert!(!back.complete, "no footer after kill -9");
    assert!(back.on(Topic::Tactile).count() > 100);
    let recorded: Vec<&Value> = back
        .on(Topic::Events)
        .filter(|m| m.json["kind"] == "located")
        .map(|m| &m.json["point"])
        .collect();
    for p in &acknowledged {
        assert!(
            recorded.contains(&p),
            "acknowledged point {p} missing from the recording"
        );
    }
    // The next daemon recovers it into a complete file with a summary saying what happened.
    drop(c);
    let (daemon2, _c2) = e2e::start_with_config(dir.path(), daemon.config.clone());
    let again = recover::read(&path).expect("recovered");
    assert!(again.complete);
    assert_eq!(again.messages.len(), back.messages.len());
    let summary: Value = serde_json::from_str(
        &std::fs::read_to_string(path.with_extension("json")).expect("summary"),
    )
    .expect("json");
    assert_eq!(summary["end_reason"], "daemon_stopped_unexpectedly");
    daemon2.stop();
}

#[test]
fn sigterm_mid_track_stops_in_control_and_closes_the_recording() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    seed(&mut c);
    call(&mut c, "track", json!({}));
    wait_event(&mut c, "a located point", |e| {
        e["event"] == "detection" && e["kind"] == "located"
    });
    assert_eq!(state(&mut c), "tracking");
    daemon.stop(); // SIGTERM; asserts exit status 0
    let path = trial_recording(dir.path());
    let back = recover::read(&path).expect("readable");
    assert!(back.complete, "the recording is closed with its footer");
    let summary: Value = serde_json::from_str(
        &std::fs::read_to_string(path.with_extension("json")).expect("summary"),
    )
    .expect("json");
    assert_eq!(summary["end_reason"], "shutdown");
    assert!(!dir.path().join("console.sock").exists(), "socket removed");
}

#[test]
fn a_full_seeded_track_completes_with_the_error_the_sim_gives() {
    let dir = tempfile::tempdir().expect("tmp");
    let setup = Setup::default();
    let (daemon, mut c) = start(dir.path(), &setup);
    seed(&mut c);
    let (_, length_m) = e2e::scene(&mut c);
    call(&mut c, "track", json!({"length_m": length_m}));
    let ended = wait_event(&mut c, "the end of the trial", |e| {
        e["event"] == "trial" && e["phase"] == "ended"
    });
    let summary = &ended["summary"];
    assert_eq!(state(&mut c), "done");
    let config_path = daemon.config.clone();
    daemon.stop();

    // The same scene, rig and seed in the simulator's lockstep runner: the same control
    // code with no threads, no sockets and no clock but the simulated one.
    let cfg = config::load_file::<config::Config>(&config_path)
        .expect("config")
        .value;
    let scene = sim::scene::load(&setup.scene, None).expect("scene");
    let lockstep = sim::runner::run_trial(&scene, &cfg, &cfg.tracker.name, setup.seed)
        .expect("lockstep trial");
    let sd_daemon = summary["lateral_error_m"]["sd"]
        .as_f64()
        .expect("daemon sd");
    let sd_sim = lockstep.lateral_error_m.sd;
    eprintln!(
        "daemon: {} points, SD {:.2} mm, {} beats; lockstep: {} points, SD {:.2} mm, {} beats",
        summary["lateral_error_m"]["n"],
        sd_daemon * 1e3,
        summary["beats"],
        lockstep.lateral_error_m.points,
        sd_sim * 1e3,
        lockstep.beats
    );
    assert_eq!(summary["completed"], true, "{summary}");
    assert!(lockstep.completed, "{:?}", lockstep.end_reason);
    assert_eq!(summary["end_reason"], lockstep.end_reason.as_str());
    // Threads and a socket shift the tracker's moves by a few cycles, so the two trials are
    // not bit-identical; their errors must agree to within what the sim's own trial-to-trial
    // spread allows.
    assert!(
        (sd_daemon - sd_sim).abs() <= 0.5 * sd_sim + 0.5e-3,
        "daemon SD {sd_daemon} m against the simulator's {sd_sim} m"
    );
    let beats = summary["beats"].as_f64().expect("beats");
    let sim_beats = lockstep.beats as f64;
    assert!(
        (beats - sim_beats).abs() <= 0.3 * sim_beats + 2.0,
        "{beats} vs {sim_beats}"
    );
}
