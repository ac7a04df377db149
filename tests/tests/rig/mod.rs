//! The emulated rig for end-to-end tests on hardware: the shipped `config/lab.ron` rewritten
//! for this machine, the emulator programs on pseudo-terminals (or the Phantom emulator in
//! this process, for tests that inject faults into it), the daemon started on it, and
//! status polling that tells a machine stall from a real failure.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::e2e::{self, T, call};

pub const LAB: &str = include_str!("../../../config/lab.ron");
pub const LAB_TACTILE: &str = "\"/dev/serial/by-id/usb-pulsetrack_tactile_array-if00\"";
pub const LAB_CAN: &str = "adapter: SocketCan(interface: \"can0\"),";

/// Lateral offset of the emulated artery from the sensor centre, m: two element pitches, so
/// a localization that ignored the array's geometry would be off by 4 mm.
pub const ARTERY_Z_M: f64 = 0.004;

/// `config/lab.ron` with what a lab changes for a session on this machine: the console
/// socket and recordings in `dir`, the tactile array at `tactile`, and the joints on
/// `joints_adapter` (RON) instead of SocketCAN.
pub fn lab_config(dir: &Path, tactile: &Path, joints_adapter: &str) -> PathBuf {
    let replace = |text: String, from: &str, to: &str| {
        assert!(text.contains(from), "config/lab.ron no longer has {from}");
        text.replace(from, to)
    };
    let mut text = LAB.to_string();
    text = replace(
        text,
        LAB_TACTILE,
        &format!("{:?}", tactile.display().to_string()),
    );
    text = replace(text, LAB_CAN, &format!("adapter: {joints_adapter},"));
    text = replace(
        text,
        "socket_path: \"/run/pulsetrack/console.sock\",",
        &format!(
            "socket_path: {:?},",
            dir.join("console.sock").display().to_string()
        ),
    );
    text = replace(
        text,
        "dir: \"/var/lib/pulsetrack/trials\",",
        &format!("dir: {:?},", dir.join("trials").display().to_string()),
    );
    // This is no RT machine: the test shares two cores with compilers and other daemons, which
    // stall every process here (1.45 s seen in the loop's period statistics and a tactile stream
    // 4.3 s old while the whole test suite ran), and the ptys deliver the amplifiers' 1 kHz
    // feedback in bursts. A second before data counts as stale (the rig: 5 ms joint feedback, 10
    // ms joints, 100 ms tactile), a thousand consecutive missed deadlines fault the loop (the rig:
    // 20), and 3 cm between setpoint and sensor (the rig: 1 cm; a stalled loop wakes to a setpoint
    // that moved on); a longer stall faults the session, which then runs again (see `Stalled`).
    text = replace(
        text,
        "feedback_timeout_s: 0.005,",
        "feedback_timeout_s: 1.0,",
    );
    text = replace(text, "stale_after_s: 0.1,", "stale_after_s: 1.0,");
    // The same stalls delay the servo's feedback by tens of ms: the rig's gains (a
    // ~250 rad/s velocity loop on the real arm, with RT priority) go unstable behind such a
    // delay, so the session runs a servo a fifth as stiff.
    text = replace(
        text,
        "    tracker: (",
        "    safety: (\n        joint_stale_s: 1.0,\n        tactile_stale_s: 1.0,\n        \
         max_sensor_error_m: 0.03,\n        max_consecutive_overruns: 1000,\n    ),\n    \
         control: (\n        pd: (\n            kp_nm_per_rad: (5.0, 4.0, 4.0),\n            \
         kd_nm_s_per_rad: (0.1, 0.08, 0.06),\n        ),\n    ),\n    tracker: (",
    );
    // The emulated arm has no gravity to compensate.
    text = replace(
        text,
        "    robot: (\n",
        "    robot: (\n        link_masses: (gravity_m_s2: 0.0),\n",
    );
    let path = dir.join("lab.ron");
    std::fs::write(&path, text).expect("write config");
    path
}

pub fn slcan(path: &Path) -> String {
    format!(
        "Slcan(path: {:?}, baud: 115200, bitrate_bps: 1000000)",
        path.display().to_string()
    )
}

/// An emulator process; killed (like pulling its USB cable) when dropped.
pub struct Emulator {
    child: Child,
    name: &'static str,
    log: PathBuf,
}

impl Emulator {
    /// Start `exe` with `args` and wait until it has created its device at `link`.
    pub fn start(name: &'static str, exe: &str, args: &[&str], dir: &Path, link: &Path) -> Self {
        let log = dir.join(format!("{name}.log"));
        let child = Command::new(exe)
            .args(args)
            // A backstop: it ends by itself even if this test process is killed.
            .args(["--duration-s", "300"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::from(std::fs::File::create(&log).expect("log")))
            .spawn()
            .unwrap_or_else(|e| panic!("spawn {name}: {e}"));
        let mut emu = Self { child, name, log };
        let deadline = Instant::now() + T;
        while std::fs::symlink_metadata(link).is_err() {
            if let Ok(Some(status)) = emu.child.try_wait() {
                panic!("{name} exited ({status}):\n{}", emu.log());
            }
            assert!(Instant::now() < deadline, "{name}: no device after 30 s");
            std::thread::sleep(Duration::from_millis(10));
        }
        emu
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// The device disappears at once: SIGKILL, no goodbye on the wire.
    pub fn unplug(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            self.unplug();
        }
        if std::thread::panicking() {
            eprintln!("--- {} log:\n{}", self.name, self.log());
        }
    }
}

pub fn tactile_emulator(dir: &Path, link: &Path) -> Emulator {
    let link_arg = link.display().to_string();
    let artery = ARTERY_Z_M.to_string();
    Emulator::start(
        "tactile-emulator",
        env!("CARGO_BIN_EXE_pt-tactile-emulator"),
        &["--link", &link_arg, "--artery-z-m", &artery, "--seed", "7"],
        dir,
        link,
    )
}

/// The emulated arm at rest with the sensor centre on the tissue at `[x, z]`.
pub fn phantom_emulator(dir: &Path, link: &Path, config: &Path, at_m: [f64; 2]) -> Emulator {
    let link_arg = link.display().to_string();
    let config_arg = config.display().to_string();
    let (x, z) = (at_m[0].to_string(), at_m[1].to_string());
    Emulator::start(
        "phantom-emulator",
        env!("CARGO_BIN_EXE_pt-phantom-emulator"),
        &[
            "--link",
            &link_arg,
            "--config",
            &config_arg,
            "--initial-sensor-m",
            &x,
            &z,
        ],
        dir,
        link,
    )
}

pub fn f(v: &Value, what: &str) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("{what} is not a number: {v}"))
}

pub fn joints(st: &Value) -> [f64; 3] {
    std::array::from_fn(|i| f(&st["arm"]["position_rad"][i], "position_rad"))
}

pub fn sensor(st: &Value) -> (f64, f64) {
    (
        f(&st["arm"]["sensor"]["x_m"], "sensor.x_m"),
        f(&st["arm"]["sensor"]["z_m"], "sensor.z_m"),
    )
}

pub type Client = daemon::console::client::Client;

/// Faults that a starved process raises correctly: data arrived too late (the stream's or
/// the joints' staleness, the CAN feedback watchdog, missed deadlines) or the arm drifted
/// from its setpoint while nobody ran (sensor error). Two cores shared with compilers stall
/// everything here for up to 1.5 s (seen in this test's status: `loop.period.max_us`).
pub const STALL_FAULTS: [&str; 5] = [
    "tactile_stale",
    "joint_stale",
    "backend",
    "deadline",
    "sensor_error",
];

/// Why a session could not conclude: the daemon faulted, rightly, because the machine
/// stalled it. Any other fault fails the test at once.
#[derive(Debug)]
pub struct Stalled(pub String);

pub fn stalled(fault: &Value, context: &Value) -> Stalled {
    let name = fault["fault"].as_str().unwrap_or("?");
    assert!(
        STALL_FAULTS.contains(&name),
        "fault {fault} (status: {context})"
    );
    Stalled(format!("{fault} (loop: {})", context["loop"]))
}

/// Poll `status` until `pred` holds; the last status. A fault meanwhile ends the session.
pub fn poll_status(
    c: &mut Client,
    what: &str,
    pred: impl Fn(&Value) -> bool,
) -> Result<Value, Stalled> {
    let deadline = Instant::now() + T;
    loop {
        let st = call(c, "status", json!({}));
        if pred(&st) {
            return Ok(st);
        }
        if st["state"] == "fault" {
            return Err(stalled(&st["fault"], &st));
        }
        assert!(Instant::now() < deadline, "never {what}: {st}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The next event matching `pred`; a fault event meanwhile ends the session.
pub fn next_event(
    c: &mut Client,
    what: &str,
    pred: impl Fn(&Value) -> bool,
) -> Result<Value, Stalled> {
    let deadline = Instant::now() + T;
    loop {
        if let Some(e) = c.next_event(Duration::from_millis(500)).expect("event") {
            if pred(&e) {
                return Ok(e);
            }
            if e["event"] == "fault" {
                let st = call(c, "status", json!({}));
                return Err(stalled(&e, &st));
            }
        }
        assert!(Instant::now() < deadline, "no {what} within 30 s");
    }
}

/// Poll `status` until `pred` holds (a fault is expected here).
pub fn poll_until(c: &mut Client, what: &str, pred: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + T;
    loop {
        let st = call(c, "status", json!({}));
        if pred(&st) {
            return st;
        }
        assert!(Instant::now() < deadline, "never {what}: {st}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Start the daemon and wait for its socket. The one start-up failure a stall causes is
/// an slcan adapter that does not answer the open sequence within its second (the emulator
/// was not scheduled): that is `Stalled`; any other early exit fails the test.
pub fn spawn_daemon(dir: &Path, config: &Path) -> Result<e2e::Running, Stalled> {
    let log = std::fs::File::create(dir.join("daemon.log")).expect("log file");
    let child = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(config)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("spawn pt-daemon");
    let mut r = e2e::Running {
        child,
        dir: dir.to_path_buf(),
        socket: dir.join("console.sock"),
        config: config.to_path_buf(),
    };
    let deadline = Instant::now() + T;
    while Client::connect(&r.socket, T).is_err() {
        if let Ok(Some(status)) = r.child.try_wait() {
            let log = r.log();
            assert!(
                log.contains("no answer from") && log.contains("slcan open sequence"),
                "the daemon exited ({status}) before listening:\n{log}"
            );
            return Err(Stalled(format!(
                "the emulated adapter did not answer: {log}"
            )));
        }
        assert!(Instant::now() < deadline, "no socket:\n{}", r.log());
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(r)
}

/// The Phantom emulator in this process, so that a test can inject faults into it (e-stop,
/// an amplifier fault) and unplug it (drop: the pty closes and its link goes), configured
/// from the daemon's `config`, at rest with the sensor centre on the tissue at `at_m`.
pub fn phantom_in_process(
    link: &Path,
    config: &Path,
    at_m: [f64; 2],
) -> drivers::can::phantom_emulator::PhantomEmulator {
    use drivers::can::phantom_emulator::{PhantomEmulator, PhantomEmulatorSettings};
    let c = config::load_file::<config::Config>(config)
        .unwrap_or_else(|e| panic!("{e}"))
        .value;
    let config::schema::Backend::Hardware(hw) = c.backend else {
        panic!("{} selects the simulator", config.display())
    };
    let mut s = PhantomEmulatorSettings::new(link);
    s.joints = hw.joints;
    s.initial_rad = drivers::programs::phantom_emulator::pose_for_sensor(&c.robot, &at_m)
        .unwrap_or_else(|e| panic!("sensor at {at_m:?}: {e}"));
    PhantomEmulator::start(s).unwrap_or_else(|e| panic!("phantom emulator at {link:?}: {e}"))
}
