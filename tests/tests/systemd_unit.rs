//! The shipped unit file passes `systemd-analyze verify` (where the tool exists).

use std::path::Path;
use std::process::Command;

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
