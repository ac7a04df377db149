//! The shipped unit file passes `systemd-analyze verify` (where the tool exists), and does
//! not restart a daemon that exits because its configuration or command line is wrong.

use std::path::Path;
use std::process::{Command, Stdio};

#[test]
fn unit_file_passes_systemd_analyze_verify() {
    let unit = Path::new(env!("CARGO_MANIFEST_DIR")).join("../daemon/systemd/pulsetrackd.service");
    let text = std::fs::read_to_string(&unit).expect("the unit file is in the repository");
    for key in [
        "Type=notify",
        "WatchdogSec=",
        "LimitRTPRIO=",
        "LimitMEMLOCK=",
        "NoNewPrivileges=yes",
        "ProtectSystem=strict",
    ] {
        assert!(text.contains(key), "the unit lacks {key}");
    }
    if Command::new("systemd-analyze")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!(
            "SKIPPED: systemd-analyze is not installed here (apt-get install systemd to run this check)"
        );
        return;
    }
    // Verify a copy whose ExecStart names the daemon this build made (verify checks that
    // the program exists and is executable).
    let dir = tempfile::tempdir().expect("tmp");
    let copy = dir.path().join("pulsetrackd.service");
    let exe = env!("CARGO_BIN_EXE_pt-daemon");
    std::fs::write(&copy, text.replace("/usr/local/bin/pulsetrackd", exe)).expect("write copy");
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&copy)
        .output()
        .expect("run systemd-analyze");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("pulsetrackd.service:"),
        "systemd-analyze verify failed:\n{stderr}"
    );
}

/// The exit status of `pt-daemon` with these arguments.
fn daemon_exit(args: &[&std::ffi::OsStr]) -> i32 {
    let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("run pt-daemon");
    out.status
        .code()
        .unwrap_or_else(|| panic!("killed: {out:?}"))
}

#[test]
fn unit_file_does_not_restart_a_daemon_whose_config_is_broken() {
    let unit = Path::new(env!("CARGO_MANIFEST_DIR")).join("../daemon/systemd/pulsetrackd.service");
    let text = std::fs::read_to_string(&unit).expect("the unit file is in the repository");
    let prevented: Vec<i32> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("RestartPreventExitStatus="))
        .flat_map(|v| {
            v.split_whitespace()
                .map(|n| n.parse::<i32>().expect("a number"))
        })
        .collect();
    assert!(
        text.contains("Restart=on-failure"),
        "the unit restarts on failure"
    );

    let dir = tempfile::tempdir().expect("tmp");
    // A config that does not parse, one that fails validation, one that is missing, and a
    // bad command line: each a mistake no restart can fix.
    let unparsable = dir.path().join("unparsable.ron");
    std::fs::write(&unparsable, "Config(version: 1, backend: ").expect("write");
    let invalid = dir.path().join("invalid.ron");
    std::fs::write(&invalid, "Config(version: 99)").expect("write");
    let missing = dir.path().join("missing.ron");
    let config = std::ffi::OsStr::new("--config");
    for (what, args) in [
        ("unparsable config", vec![config, unparsable.as_os_str()]),
        ("invalid config", vec![config, invalid.as_os_str()]),
        ("missing config", vec![config, missing.as_os_str()]),
        (
            "unknown option",
            vec![std::ffi::OsStr::new("--no-such-option")],
        ),
    ] {
        let code = daemon_exit(&args);
        assert!(
            prevented.contains(&code),
            "{what}: pulsetrackd exits {code}, which RestartPreventExitStatus= ({prevented:?}) \
             does not list: systemd would restart it every RestartSec for ever"
        );
    }
}
