//! `pulsetrack` writing into a pipe whose reader has gone (`pulsetrack status | head -1`):
//! it must end quietly with status 0, never panic in `println!`.

use std::process::{Command, Stdio};

#[test]
fn a_closed_stdout_pipe_ends_the_command_quietly() {
    let config = concat!(env!("CARGO_MANIFEST_DIR"), "/../config/sim.ron");
    let mut child = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["check-config", config])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn pt-console");
    // Close the reading end before the program writes its first line.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait for pt-console");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "stderr: {stderr}");
    assert_eq!(out.status.code(), Some(0), "stderr: {stderr}");
}
