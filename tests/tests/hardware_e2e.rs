//! End to end on emulated hardware: the real daemon (`pulsetrackd`, built here as
//! `pt-daemon`) with `backend: Hardware(...)` from the shipped `config/lab.ron`, its real
//! drivers talking to the real emulator programs on pseudo-terminals: the tactile array's
//! serial protocol (`tactile-emulator`) and the Phantom's amplifiers behind an slcan USB-CAN
//! adapter (`phantom-emulator`; this kernel has no AF_CAN). Driven over the console socket.
//!
//! Wall-clock time (the rig's clock is real), but every wait polls for a condition under a
//! generous deadline; nothing asserts how long anything took.

mod e2e;
mod rig;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use e2e::{T, call, state, wait_event};
use rig::{
    ARTERY_Z_M, Client, Stalled, f, joints, lab_config, next_event, phantom_emulator, poll_status,
    poll_until, sensor, slcan, spawn_daemon, tactile_emulator,
};
use serde_json::json;

#[test]
fn hardware_daemon_tracks_the_emulated_rig_and_stops_safely_when_the_array_is_unplugged() {
    const ATTEMPTS: usize = 5;
    for attempt in 1..=ATTEMPTS {
        match emulated_rig_session() {
            Ok(()) => return,
            Err(Stalled(why)) => {
                eprintln!("attempt {attempt}/{ATTEMPTS}: the machine stalled the daemon: {why}");
            }
        }
    }
    panic!("the machine stalled the daemon in each of {ATTEMPTS} sessions (above)");
}

fn emulated_rig_session() -> Result<(), Stalled> {
    let dir = tempfile::tempdir().expect("tmp");
    let (tactile_link, can_link) = (dir.path().join("tactile"), dir.path().join("slcan"));
    let config = lab_config(dir.path(), &tactile_link, &slcan(&can_link));
    let mut array = tactile_emulator(dir.path(), &tactile_link);
    let _arm = phantom_emulator(dir.path(), &can_link, &config, [0.0, 0.0]);
    let daemon = spawn_daemon(dir.path(), &config)?;
    let mut c = Client::connect(&daemon.socket, T).expect("connect");
    poll_status(&mut c, "tactile frames", |s| {
        s["tactile"]["frames"].as_u64().unwrap_or(0) > 0
    })?;

    assert_eq!(c.hello["hello"], "pulsetrackd", "{}", c.hello);
    assert_eq!(c.hello["backend"], "hardware", "{}", c.hello);
    let st = call(&mut c, "status", json!({}));
    assert_eq!(st["backend"]["kind"], "hardware", "{st}");
    assert_eq!(st["backend"]["wall_clock_bound"], true, "{st}");
    assert_eq!(st["state"], "disabled", "{st}");
    // The emulator's encoders put the sensor where it was started.
    let (x0, z0) = sensor(&st);
    assert!(
        x0.abs() < 1e-3 && z0.abs() < 1e-3,
        "sensor at ({x0}, {z0}): {st}"
    );
    let q0 = joints(&st);

    call(
        &mut c,
        "subscribe",
        json!({"streams": ["state", "detections", "faults"]}),
    );
    let r = c.request("enable", json!({}), T).expect("reply");
    if r["ok"] != true {
        // Refused while a cause is present: only stale data can be, here.
        let why = r["reason"].as_str().unwrap_or("");
        assert!(why.contains("stale"), "enable refused: {r}");
        return Err(Stalled(format!("enable refused: {r}")));
    }
    poll_status(&mut c, "holding", |s| s["state"] == "holding")?;

    // The daemon's torques go out over slcan, the emulated joints turn, the encoders come
    // back: the joint state moves with the emulated arm.
    let target = (0.010, 0.0);
    call(&mut c, "move", json!({"x_m": target.0, "z_m": target.1}));
    let st = poll_status(&mut c, "at the target", |s| {
        s["state"] == "holding" && s["arm"]["settled"] == true
    })?;
    let q1 = joints(&st);
    let moved = (0..3).map(|i| (q1[i] - q0[i]).abs()).fold(0.0, f64::max);
    assert!(moved > 0.01, "joints {q0:?} -> {q1:?}: {st}");
    let (x1, z1) = sensor(&st);
    assert!(
        (x1 - target.0).abs() < 2e-3 && (z1 - target.1).abs() < 2e-3,
        "sensor at ({x1}, {z1}), asked for {target:?}: {st}"
    );

    // A pulse goes in at the emulated array and a localization comes out of the daemon.
    // A placement still moving at its settling deadline (a loaded machine) is marked once
    // it rests within the arrival tolerance: the daemon judges it afresh at the mark.
    call(&mut c, "mark", json!({}));
    let e = next_event(&mut c, "the mark's result", |e| {
        e["event"] == "detection" && (e["kind"] == "located" || e["kind"] == "missed")
    })?;
    assert_eq!(e["kind"], "located", "{e}");
    let p = &e["point"];
    let (sx, sz) = (
        f(&p["sensor_x_m"], "sensor_x_m"),
        f(&p["sensor_z_m"], "sensor_z_m"),
    );
    assert!((f(&p["x_m"], "x_m") - sx).abs() < 1e-9, "{e}");
    assert!(
        (f(&p["z_m"], "z_m") - (sz + ARTERY_Z_M)).abs() < 1e-3,
        "artery {ARTERY_Z_M} m beside the sensor centre, located at {e}"
    );
    assert!((f(&p["element"], "element") - 6.5).abs() < 0.5, "{e}");
    poll_status(&mut c, "holding after the mark", |s| {
        s["state"] == "holding"
    })?;

    // Start a move and pull the array's cable: the stream goes stale, the fault latches
    // and the arm is powered off and comes to rest.
    call(&mut c, "move", json!({"x_m": 0.0, "z_m": 0.0}));
    array.unplug();
    let e = wait_event(&mut c, "the fault", |e| e["event"] == "fault");
    assert_eq!(e["fault"], "tactile_stale", "{e}");
    let st = poll_until(&mut c, "unpowered", |s| {
        s["state"] == "fault"
            && s["arm"]["mode"] == "faulted"
            && (0..3).all(|i| s["arm"]["torque_nm"][i].as_f64() == Some(0.0))
    });
    assert_eq!(st["fault"]["fault"], "tactile_stale", "{st}");
    // Unpowered, it coasts to rest (the emulated joints' damping): the encoders stop
    // changing from one look to the next, 100 ms apart.
    let deadline = Instant::now() + T;
    let mut q_before = joints(&st);
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let st = call(&mut c, "status", json!({}));
        assert!(
            (0..3).all(|i| st["arm"]["torque_nm"][i].as_f64() == Some(0.0)),
            "torque while faulted: {st}"
        );
        let q = joints(&st);
        if (0..3).all(|i| q[i] == q_before[i]) {
            break;
        }
        assert!(Instant::now() < deadline, "still moving: {st}");
        q_before = q;
    }
    assert!(
        daemon.log().contains(&tactile_link.display().to_string()),
        "the log names the unplugged device:\n{}",
        daemon.log()
    );
    assert_eq!(state(&mut c), "fault");

    daemon.stop();
    Ok(())
}

fn check_config(path: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .arg("check-config")
        .arg(path)
        .output()
        .expect("run pt-console")
}

#[test]
fn hardware_lab_config_as_shipped_passes_check_config() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/lab.ron");
    let out = check_config(&path);
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Run the daemon on a config expected to be refused; its exit and everything it said.
fn refused_start(config: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(config)
        .stdin(Stdio::null())
        .output()
        .expect("run pt-daemon");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!out.status.success(), "started anyway:\n{text}");
    assert!(!text.contains("panicked"), "{text}");
    text
}

#[test]
fn hardware_missing_devices_are_named_not_panicked_over() {
    let dir = tempfile::tempdir().expect("tmp");
    let gone_tactile = dir.path().join("no-such-tactile");
    let gone_can = dir.path().join("no-such-usb-can");

    // The joints' adapter must open at start: a missing one stops the daemon with its name.
    let config = lab_config(dir.path(), &gone_tactile, &slcan(&gone_can));
    let out = check_config(&config);
    assert!(out.status.success(), "{out:?}");
    let text = refused_start(&config);
    assert!(
        text.contains(&gone_can.display().to_string()),
        "names the device:\n{text}"
    );

    // As shipped (SocketCAN on can0): this kernel has no CAN, and the message says so.
    let config = lab_config(dir.path(), &gone_tactile, "SocketCan(interface: \"can0\")");
    let text = refused_start(&config);
    assert!(text.contains("can0"), "names the interface:\n{text}");

    // The array may be plugged in later: the daemon runs, names the missing device and
    // refuses to power the arm without tactile data.
    let arm_link = dir.path().join("slcan");
    let config = lab_config(dir.path(), &gone_tactile, &slcan(&arm_link));
    let _arm = phantom_emulator(dir.path(), &arm_link, &config, [0.0, 0.0]);
    let running = (0..5)
        .find_map(|_| spawn_daemon(dir.path(), &config).ok())
        .expect("the daemon started in one of 5 tries");
    let deadline = Instant::now() + T;
    while !running.log().contains(&gone_tactile.display().to_string()) {
        assert!(
            Instant::now() < deadline,
            "the log never names {}:\n{}",
            gone_tactile.display(),
            running.log()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut c = Client::connect(&running.socket, T).expect("connect");
    let r = c.request("enable", json!({}), T).expect("reply");
    assert_eq!(r["ok"], false, "{r}");
    assert!(
        r["reason"].as_str().is_some_and(|s| s.contains("tactile")),
        "{r}"
    );
    assert_eq!(state(&mut c), "disabled");
    running.stop();
}
