//! The command line's exit codes and its JSON errors (docs/cli.md): 0 ok, 1 failed, 2 usage;
//! with `--json` a failure is one JSON object on stderr and stdout stays empty.

use std::process::{Command, Output, Stdio};

fn pulsetrack(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(args)
        .env_remove("PULSETRACK_SOCKET")
        .stdin(Stdio::null())
        .output()
        .expect("run pt-console")
}

/// The one JSON object on stderr.
fn json_error(out: &Output) -> serde_json::Value {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line on stderr: {stderr}");
    serde_json::from_str(lines[0]).unwrap_or_else(|e| panic!("{e}: {stderr}"))
}

#[test]
fn a_bad_value_is_a_usage_error_naming_the_flag() {
    let out = pulsetrack(&["move", "--x-mm", "nan", "--z-mm", "0"]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--x-mm") && stderr.contains("not a finite number"),
        "{stderr}"
    );
    let out = pulsetrack(&[
        "move", "--x-mm", "12", "--x-m", "0.012", "--z-mm", "0", "--json",
    ]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert!(out.stdout.is_empty(), "{out:?}");
    let e = json_error(&out);
    assert_eq!(e["ok"], false);
    assert_eq!(e["error"], "usage");
    assert_eq!(e["command"], "move");
    assert_eq!(e["exit_code"], 2);
    let reason = e["reason"].as_str().expect("reason");
    assert!(
        reason.contains("--x-mm") && reason.contains("--x-m"),
        "{reason}"
    );
}

#[test]
fn an_unreachable_daemon_is_exit_1_and_json_with_json() {
    let dir = tempfile::tempdir().expect("tmp");
    let sock = dir.path().join("no-daemon.sock");
    let sock = sock.to_str().expect("UTF-8 path");
    let out = pulsetrack(&["status", "--socket", sock]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-daemon.sock"));
    let out = pulsetrack(&["status", "--json", "--socket", sock]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(out.stdout.is_empty(), "{out:?}");
    let e = json_error(&out);
    assert_eq!(e["error"], "unreachable");
    assert_eq!(e["command"], "status");
    assert!(
        e["reason"]
            .as_str()
            .expect("reason")
            .contains("no-daemon.sock"),
        "{e}"
    );
}

#[test]
fn a_failing_tool_is_exit_1_and_json_with_json() {
    let out = pulsetrack(&["sim", "--scene", "no-such-scene.ron", "--json"]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(out.stdout.is_empty(), "{out:?}");
    let e = json_error(&out);
    assert_eq!(
        (e["error"].as_str(), e["command"].as_str()),
        (Some("failed"), Some("sim"))
    );
    assert!(
        e["reason"]
            .as_str()
            .expect("reason")
            .contains("no-such-scene"),
        "{e}"
    );
    let dir = tempfile::tempdir().expect("tmp");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, "Scene(name: ").expect("write");
    let out = pulsetrack(&["check-config", bad.to_str().expect("UTF-8"), "--json"]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(
        json_error(&out)["reason"]
            .as_str()
            .expect("reason")
            .contains("bad.ron")
    );
}

#[test]
fn generated_help_completions_and_pages_exit_0() {
    for args in [
        &["--help"][..],
        &["completions", "bash"],
        &["man"],
        &["move", "--help"],
    ] {
        let out = pulsetrack(args);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {out:?}");
        assert!(!out.stdout.is_empty(), "{args:?}");
    }
}

#[test]
fn recover_with_json_gives_a_line_per_file_and_json_errors() {
    let dir = tempfile::tempdir().expect("tmp");
    let good = dir.path().join("trial.mcap");
    let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../daemon/tests/fixtures/v0-trial.mcap");
    std::fs::copy(&fixture, &good).expect("copy the fixture");
    let bad = dir.path().join("garbage.mcap");
    std::fs::write(&bad, b"\x89MCAP0\r\n not really").expect("write");
    let out = pulsetrack(&[
        "recover",
        "--json",
        good.to_str().expect("UTF-8"),
        bad.to_str().expect("UTF-8"),
    ]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    assert_eq!(lines.len(), 1, "{stdout}");
    assert!(
        lines[0]["file"]
            .as_str()
            .expect("file")
            .ends_with("trial.mcap")
    );
    let e = json_error(&out);
    assert_eq!(
        (e["error"].as_str(), e["command"].as_str()),
        (Some("failed"), Some("recover"))
    );
    assert!(
        e["reason"]
            .as_str()
            .expect("reason")
            .contains("garbage.mcap"),
        "{e}"
    );
}
