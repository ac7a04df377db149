//! The whole daemon in process (loop thread, supervisor, recorder, console server) on a test
//! double of the ports, servo and tracker, driven over its real Unix socket.

mod double;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use pulsetrack_daemon::console::client::Client;
use pulsetrack_daemon::pulsetrackd::{Daemon, LoadedConfig, Parts};
use pulsetrack_daemon::recording::recover;
use pulsetrack_daemon::recording::topics::Topic;
use serde_json::{Value, json};

const T: Duration = Duration::from_secs(10);

fn start(dir: &Path) -> (Daemon, Client) {
    start_with(dir, None)
}

fn start_with(dir: &Path, wall_x_m: Option<f64>) -> (Daemon, Client) {
    start_with_servo(dir, wall_x_m, double::FakeServo::default())
}

/// The daemon on the double, joint 0 (the sensor's x) stopped at `wall_x_m` if given.
fn start_with_servo(
    dir: &Path,
    wall_x_m: Option<f64>,
    servo: double::FakeServo,
) -> (Daemon, Client) {
    pulsetrack_daemon::service::logging::init("warn");
    let mut loaded = LoadedConfig::load(None).expect("embedded config");
    let c = &mut loaded.config;
    c.console.socket_path = dir.join("console.sock").display().to_string();
    c.recording.dir = dir.join("trials").display().to_string();
    c.console.debug_hooks = true;
    c.console.max_line_bytes = 1024;
    c.console.max_requests_per_s = 50.0;
    c.realtime.lock_memory = false;
    // Tests run side by side: any free port for the live view.
    c.live.port = 0;
    let daemon = Daemon::start_with(
        loaded,
        Parts {
            backend: double::backend_with_wall(wall_x_m),
            servo: Box::new(servo),
            tracker: Box::new(|_| Ok(Box::new(double::FakeTracker::new()))),
        },
    )
    .expect("daemon starts");
    let mut client = Client::connect(daemon.socket_path(), T).expect("connect");
    // Enabling needs a live tactile stream: wait for the first frames.
    let deadline = Instant::now() + T;
    while call(&mut client, "status", json!({}))["tactile"]["frames"]
        .as_u64()
        .unwrap_or(0)
        == 0
    {
        assert!(Instant::now() < deadline, "no tactile frames");
        std::thread::sleep(Duration::from_millis(5));
    }
    (daemon, client)
}

fn call(c: &mut Client, verb: &str, args: Value) -> Value {
    let r = c.request(verb, args, T).expect("reply");
    assert_eq!(r["ok"], true, "{verb} refused: {r}");
    r
}

fn state(c: &mut Client) -> String {
    call(c, "status", json!({}))["state"]
        .as_str()
        .unwrap_or("?")
        .to_string()
}

fn wait_state(c: &mut Client, want: &str) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let s = state(c);
        if s == want {
            return;
        }
        assert!(Instant::now() < deadline, "still {s}, wanted {want}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_seeded_trial_runs_to_its_length_and_is_recorded() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path());
    assert_eq!(c.hello["protocol"], 1);
    assert_eq!(c.hello["state"], "disabled");
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["trials", "detections", "faults"]}),
    );
    call(&mut c, "enable", json!({}));
    assert_eq!(state(&mut c), "holding");
    call(&mut c, "move", json!({"x_m": 0.01, "z_m": 0.0}));
    wait_state(&mut c, "holding");
    call(&mut c, "mark", json!({}));
    wait_state(&mut c, "holding");
    call(&mut c, "move", json!({"x_m": 0.02, "z_m": 0.001}));
    wait_state(&mut c, "holding");
    call(&mut c, "mark", json!({}));
    wait_state(&mut c, "holding");
    call(&mut c, "track", json!({"length_m": 0.02}));
    let summary = loop {
        let e = c
            .next_event(Duration::from_secs(60))
            .expect("event")
            .expect("an event");
        if e["event"] == "fault" {
            panic!("fault: {e}");
        }
        if e["event"] == "trial" && e["phase"] == "ended" {
            break e["summary"].clone();
        }
    };
    assert_eq!(summary["completed"], true, "{summary}");
    assert_eq!(summary["end_reason"], "length_reached");
    assert!(summary["followed_m"].as_f64().expect("followed") >= 0.02);
    assert_eq!(state(&mut c), "done");
    let recording = PathBuf::from(summary["recording"].as_str().expect("path"));
    // The summary beside the recording, and a complete recording.
    let json_path = recording.with_extension("json");
    let on_disk: Value =
        serde_json::from_str(&std::fs::read_to_string(&json_path).expect("summary file"))
            .expect("json");
    assert_eq!(on_disk["end_reason"], "length_reached");
    let back = recover::read(&recording).expect("readable");
    assert!(back.complete);
    assert!(back.on(Topic::Tactile).count() > 100);
    assert!(back.on(Topic::Joints).count() > 100);
    let located = back
        .on(Topic::Events)
        .filter(|m| m.json["kind"] == "located")
        .count();
    assert_eq!(
        located,
        summary["located"].as_array().map(Vec::len).unwrap_or(0)
    );
    daemon.shutdown().expect("clean stop");
}

#[test]
fn verbs_in_the_wrong_state_are_refused_with_a_reason() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path());
    for (verb, args, why) in [
        (
            "track",
            json!({}),
            "cannot track while disabled: enable first",
        ),
        (
            "move",
            json!({"x_m": 0.0, "z_m": 0.0}),
            "cannot move while disabled: enable first",
        ),
        ("reset", json!({}), "no fault is latched"),
        ("pause", json!({}), "nothing is tracking"),
    ] {
        let r = c.request(verb, args, T).expect("reply");
        assert_eq!(r["ok"], false, "{verb}: {r}");
        assert_eq!(r["error"], "wrong_state");
        assert!(r["reason"].as_str().expect("reason").contains(why), "{r}");
        assert_eq!(r["state"], "disabled");
    }
    call(&mut c, "enable", json!({}));
    let r = c.request("track", json!({}), T).expect("reply");
    assert!(
        r["reason"].as_str().expect("reason").contains("have 0"),
        "{r}"
    );
    let r = c.request("enable", json!({}), T).expect("reply");
    assert!(
        r["reason"]
            .as_str()
            .expect("reason")
            .contains("already enabled"),
        "{r}"
    );
    // A move outside the workspace is refused before it reaches the loop.
    let r = c
        .request("move", json!({"x_m": 0.9, "z_m": 0.0}), T)
        .expect("reply");
    assert_eq!(r["error"], "out_of_range", "{r}");
    assert_eq!(state(&mut c), "holding");
    daemon.shutdown().expect("clean stop");
}

#[test]
fn a_stale_tactile_stream_faults_and_only_reset_recovers() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path());
    call(&mut c, "subscribe", json!({"streams": ["faults"]}));
    call(&mut c, "enable", json!({}));
    call(
        &mut c,
        "debug",
        json!({"action": "silence_tactile", "duration_s": 0.5}),
    );
    let fault = c.next_event(T).expect("event").expect("fault event");
    assert_eq!(fault["event"], "fault");
    assert_eq!(fault["fault"], "tactile_stale");
    let dump = fault["flight_recorder"].as_str().expect("dump path");
    assert!(std::fs::read_to_string(dump).expect("dump").lines().count() > 100);
    assert_eq!(state(&mut c), "fault");
    // The stream comes back, but the fault stays latched: nothing resumes by itself.
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(state(&mut c), "fault");
    let r = c.request("enable", json!({}), T).expect("reply");
    assert!(
        r["reason"]
            .as_str()
            .expect("reason")
            .contains("reset first"),
        "{r}"
    );
    call(&mut c, "reset", json!({}));
    assert_eq!(state(&mut c), "disabled");
    // Enabling needs a live stream again; retry while the silence lasts.
    let deadline = Instant::now() + T;
    loop {
        let r = c.request("enable", json!({}), T).expect("reply");
        if r["ok"] == true {
            break;
        }
        assert!(Instant::now() < deadline, "{r}");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(state(&mut c), "holding");
    daemon.shutdown().expect("clean stop");
}

#[test]
fn bad_lines_get_errors_and_the_next_request_works() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path());
    c.send_raw(b"this is not json\n").expect("send");
    let r = c.reply_to(None, T).expect("reply");
    assert_eq!(
        (r["ok"].clone(), r["error"].clone()),
        (json!(false), json!("malformed"))
    );
    let mut long = vec![b'x'; 5000];
    long.push(b'\n');
    c.send_raw(&long).expect("send");
    let r = c.reply_to(None, T).expect("reply");
    assert_eq!(r["error"], "line_too_long", "{r}");
    let r = c.request("fly", json!({}), T).expect("reply");
    assert_eq!(r["error"], "unknown_verb");
    let r = c
        .request("move", json!({"x_m": "far", "z_m": 0}), T)
        .expect("reply");
    assert_eq!(r["error"], "bad_argument");
    // A flood: many requests at once; some are refused as a flood, none crash anything.
    let mut burst = Vec::new();
    for i in 0..200 {
        burst
            .extend_from_slice(format!("{{\"id\":{},\"verb\":\"status\"}}\n", 1000 + i).as_bytes());
    }
    c.send_raw(&burst).expect("send");
    let mut floods = 0;
    for _ in 0..200 {
        let r = c.reply_to(None, T).expect("reply");
        if r["error"] == "flood" {
            floods += 1;
        }
    }
    assert!(floods > 0, "no flood errors");
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(state(&mut c), "disabled");
    daemon.shutdown().expect("clean stop");
}

/// Enable, move the sensor to x = 10 mm, and wait for the loop to say the move stopped
/// short: that event.
fn move_until_stopped_short(c: &mut Client) -> Value {
    call(c, "subscribe", json!({"streams": ["state"]}));
    call(c, "enable", json!({}));
    call(c, "move", json!({"x_m": 0.01, "z_m": 0.0}));
    loop {
        let e = c
            .next_event(Duration::from_secs(60))
            .expect("event")
            .expect("an event");
        if e["event"] == "motion" && e["kind"] == "stopped_short" {
            return e;
        }
    }
}

/// Ask to mark until the daemon takes it (30 s at most); every refusal must be a "cannot
/// mark" one (the arm not yet there).
fn mark_once_allowed(c: &mut Client) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let r = c.request("mark", json!({}), T).expect("reply");
        if r["ok"] == true {
            return;
        }
        assert!(
            r["reason"].as_str().unwrap_or("").contains("cannot mark"),
            "{r}"
        );
        assert!(Instant::now() < deadline, "mark still refused: {r}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn mark_is_refused_when_the_arm_stops_short_and_says_by_how_much() {
    let dir = tempfile::tempdir().expect("tmp");
    // The arm cannot pass x = 4 mm: a move to 10 mm stops 6 mm short.
    let (daemon, mut c) = start_with(dir.path(), Some(0.004));
    // The stop short is announced with the shortfall in m and in words.
    let ev = move_until_stopped_short(&mut c);
    let short = ev["shortfall_m"].as_f64().expect("shortfall_m");
    assert!((short - 0.006).abs() < 5e-4, "{ev}");
    assert_eq!(ev["reason"], "stalled");
    wait_state(&mut c, "holding");
    let r = c.request("mark", json!({}), T).expect("reply");
    assert_eq!(r["ok"], false, "marked where the arm did not get: {r}");
    let text = r.to_string();
    assert!(text.contains("mm short") && text.contains("6.0"), "{text}");
    // Nothing was marked: no trial, no seed.
    let status = call(&mut c, "status", json!({}));
    assert!(status["trial"].is_null(), "{status}");
    // A move that arrives makes marking possible again.
    call(&mut c, "move", json!({"x_m": 0.003, "z_m": 0.0}));
    wait_state(&mut c, "holding");
    mark_once_allowed(&mut c);
    daemon.shutdown().expect("clean stop");
}

#[test]
fn a_placement_still_moving_at_its_deadline_is_marked_once_it_rests_there() {
    let dir = tempfile::tempdir().expect("tmp");
    // The first move is still moving when its settling time runs out, though already within
    // the arrival tolerance (a loaded machine, an arm ringing): the loop judges it short of
    // its target, not at rest, and holds. Resting there, the arm has arrived after all.
    let (daemon, mut c) = start_with_servo(dir.path(), None, double::FakeServo::restless(1));
    let ev = move_until_stopped_short(&mut c);
    assert_eq!(ev["reason"], "not_at_rest", "{ev}");
    wait_state(&mut c, "holding");
    // The hold comes to rest within a few cycles; from then on the mark is taken.
    mark_once_allowed(&mut c);
    let status = call(&mut c, "status", json!({}));
    assert!(
        !status["trial"].is_null(),
        "the mark started no trial: {status}"
    );
    daemon.shutdown().expect("clean stop");
}

#[test]
fn a_placement_still_moving_at_its_deadline_far_from_its_target_is_not_marked() {
    let dir = tempfile::tempdir().expect("tmp");
    // As above, but the arm cannot pass x = 4 mm: it rests 6 mm from the placement.
    let (daemon, mut c) = start_with_servo(dir.path(), Some(0.004), double::FakeServo::restless(1));
    let ev = move_until_stopped_short(&mut c);
    assert_eq!(ev["reason"], "not_at_rest", "{ev}");
    wait_state(&mut c, "holding");
    // Time for the hold to come to rest, 6 mm from the placement.
    std::thread::sleep(Duration::from_millis(300));
    let r = c.request("mark", json!({}), T).expect("reply");
    assert_eq!(r["ok"], false, "marked where the arm did not get: {r}");
    let status = call(&mut c, "status", json!({}));
    assert!(status["trial"].is_null(), "{status}");
    daemon.shutdown().expect("clean stop");
}
