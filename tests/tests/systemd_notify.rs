//! The daemon tells systemd it is ready and feeds the watchdog, through sd_notify: checked
//! with a notification socket of our own, as systemd would provide it.

mod e2e;

use std::os::unix::net::UnixDatagram;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn readiness_and_watchdog_notifications_reach_the_notify_socket() {
    let dir = tempfile::tempdir().expect("tmp");
    let notify_path = dir.path().join("notify.sock");
    let sock = UnixDatagram::bind(&notify_path).expect("bind notify socket");
    sock.set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let config = e2e::write_config(dir.path(), &e2e::Setup::default());
    let log_path = dir.path().join("daemon.log");
    let log = std::fs::File::create(&log_path).expect("log file");
    let mut child = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(&config)
        .env("NOTIFY_SOCKET", &notify_path)
        .env("WATCHDOG_USEC", "200000")
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("spawn");
    // WATCHDOG_PID unset: sd_notify then accepts the watchdog for any process.
    let mut seen = String::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut buf = [0u8; 4096];
    while Instant::now() < deadline && !(seen.contains("READY=1") && seen.contains("WATCHDOG=1")) {
        if let Ok(n) = sock.recv(&mut buf) {
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
            seen.push('\n');
        }
    }
    let _ = Command::new("kill")
        .arg("-15")
        .arg(child.id().to_string())
        .status();
    let status = child.wait().expect("wait");
    assert!(seen.contains("READY=1"), "notifications: {seen:?}");
    assert!(seen.contains("WATCHDOG=1"), "notifications: {seen:?}");
    assert!(status.success(), "{status}");
    // A daemon that fed the watchdog never starved it: no false alarm at start (every
    // start logged one, judging progress before the loop had counted anything).
    let log = std::fs::read_to_string(&log_path).expect("read log");
    assert!(
        !log.contains("not feeding the watchdog"),
        "false watchdog alarm:\n{log}"
    );
}
