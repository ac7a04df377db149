//! `beatslide`'s first mark from both sides through the real daemon on the simulated bench:
//! with `seat_stroke_m` set, the first mark strokes the arm out along +z and back, marks, does
//! the same along -z, and reports the midpoint once (the daemon carries out a marking
//! tracker's moves, as the lockstep runner does); the trial is recorded so that replay
//! reproduces it bit for bit.

mod e2e;

use std::process::Command;
use std::time::Duration;

use daemon::console::client::Client;
use e2e::{
    Setup, call, scene, start_with_config, track_to_recording, wait_event, wait_state, write_config,
};
use serde_json::{Value, json};

fn sensor(c: &mut Client) -> (f64, f64) {
    let st = call(c, "status", json!({}));
    let s = &st["arm"]["sensor"];
    (
        s["x_m"].as_f64().expect("sensor x"),
        s["z_m"].as_f64().expect("sensor z"),
    )
}

/// The daemon on the shipped sim config with `beatslide` seating by 8 mm, simulating
/// `time_scale` times faster than real time.
fn start_seating(dir: &std::path::Path, time_scale: f64) -> (e2e::Running, Client) {
    let setup = Setup {
        time_scale,
        ..Setup::default()
    };
    let config = write_config(dir, &setup);
    let text = std::fs::read_to_string(&config).expect("config");
    let seated = text.replace(
        "name: \"seed2002\",",
        "name: \"beatslide\", params: (beatslide: (seat_stroke_m: 0.008)),",
    );
    assert_ne!(
        text, seated,
        "the shipped sim config no longer names seed2002"
    );
    std::fs::write(&config, seated).expect("write config");
    start_with_config(dir, config)
}

/// Subscribe to what the tests wait for, power the arm; the scene's placements.
fn enable_and_subscribe(c: &mut Client) -> [(f64, f64); 2] {
    call(
        c,
        "subscribe",
        json!({"streams": ["state", "detections", "faults", "trials"]}),
    );
    let (placements, _) = scene(c);
    call(c, "enable", json!({}));
    placements
}

/// Move onto `at` and wait until the arm holds there; where the sensor then is.
fn move_onto(c: &mut Client, at: (f64, f64)) -> (f64, f64) {
    call(c, "move", json!({"x_m": at.0, "z_m": at.1}));
    wait_state(c, "holding");
    sensor(c)
}

#[test]
fn the_first_mark_seats_the_sensor_and_the_trial_replays_bit_for_bit() {
    let dir = tempfile::tempdir().expect("tmp");
    // Slow enough that the status polls see each stroke (40x would step over them).
    let (daemon, mut c) = start_seating(dir.path(), 4.0);
    let placements = enable_and_subscribe(&mut c);

    // The first placement, then its mark: the arm leaves the placement by most of the
    // stroke (the seed's PD stops short of a move's end), to both sides, and comes back
    // before the one result.
    let home = move_onto(&mut c, placements[0]);
    call(&mut c, "mark", json!({}));
    let mut farthest: f64 = 0.0;
    let (mut above, mut below): (f64, f64) = (0.0, 0.0);
    let result = loop {
        let (x, z) = sensor(&mut c);
        farthest = farthest.max((x - home.0).hypot(z - home.1));
        above = above.max(z - home.1);
        below = below.min(z - home.1);
        match c.next_event(Duration::from_millis(20)).expect("event") {
            Some(e) if e["event"] == "detection" && e["kind"] != "pulse" => break e,
            Some(e) => assert!(e["event"] != "fault", "fault while marking: {e}"),
            None => {}
        }
    };
    assert_eq!(result["kind"], "located", "{result}");
    assert!(
        (0.004..0.012).contains(&farthest),
        "the arm went {:.1} mm from the placement while marking",
        farthest * 1e3
    );
    assert!(
        above > 0.003 && below < -0.003,
        "the strokes went {:.1} mm to +z and {:.1} mm to -z",
        above * 1e3,
        below * 1e3
    );
    let back = sensor(&mut c);
    assert!(
        (back.0 - home.0).hypot(back.1 - home.1) < 0.006,
        "the mark ended {back:?}, the placement was {home:?}"
    );

    // The second placement is marked where it is (no stroke), then a short track.
    let (x1, z1) = placements[1];
    wait_state(&mut c, "holding");
    move_onto(&mut c, (x1, z1));
    call(&mut c, "mark", json!({}));
    let e = wait_event(&mut c, "the second mark's result", |e| {
        e["event"] == "detection" && (e["kind"] == "located" || e["kind"] == "missed")
    });
    assert_eq!(e["kind"], "located", "{e}");
    wait_state(&mut c, "holding");
    let (_, _, file) = track_to_recording(daemon, &mut c, 0.03);

    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["replay", &file, "--tracker", "beatslide", "--json"])
        .output()
        .expect("run pulsetrack replay");
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or(Value::Null);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(doc["identical_to_recorded"], true, "{doc}");
}

#[test]
fn stop_during_the_stroke_holds_the_arm_and_the_next_mark_needs_no_restart() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start_seating(dir.path(), Setup::default().time_scale);
    let placements = enable_and_subscribe(&mut c);
    let home = move_onto(&mut c, placements[0]);
    call(&mut c, "mark", json!({}));
    // Stop once the stroke is under way.
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    loop {
        let (x, z) = sensor(&mut c);
        if (x - home.0).hypot(z - home.1) > 0.002 {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the stroke never began"
        );
    }
    call(&mut c, "stop", json!({}));
    let ended = wait_event(&mut c, "the abandoned trial", |e| {
        e["event"] == "trial" && e["phase"] == "ended"
    });
    assert_eq!(ended["summary"]["end_reason"], "abandoned", "{ended}");
    wait_state(&mut c, "done");
    // The arm stays where it stopped: the tracker moves it no more.
    let a = sensor(&mut c);
    std::thread::sleep(Duration::from_millis(300));
    let b = sensor(&mut c);
    assert!(
        (a.0 - b.0).hypot(a.1 - b.1) < 5e-4,
        "the arm moved from {a:?} to {b:?} after stop"
    );
    // No restart: back onto the placement, and a new trial's first mark seats and finds it.
    move_onto(&mut c, placements[0]);
    call(&mut c, "mark", json!({}));
    let e = wait_event(&mut c, "the new mark's result", |e| {
        e["event"] == "detection" && (e["kind"] == "located" || e["kind"] == "missed")
    });
    assert_eq!(e["kind"], "located", "{e}");
    daemon.stop();
}
