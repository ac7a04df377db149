//! How the command line reports a failure and which exit code it gives (docs/cli.md): one
//! line `pulsetrack CMD: reason` on stderr, or, with `--json`, one JSON object on stderr
//! (`{"ok":false,"error":CODE,"command":CMD,"reason":TEXT,"exit_code":N}`), so that stdout
//! only ever carries results.

use std::process::ExitCode;

use serde_json::json;

/// What went wrong, as the `error` code of the JSON form and the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// The command ran and failed: a file, a scene, a model, a refused request, a trial
    /// that did not complete. Exit 1.
    Failed,
    /// The daemon's socket could not be reached or was not trusted. Exit 1.
    Unreachable,
    /// The command line itself is wrong (an unknown flag, a bad value). Exit 2.
    Usage,
}

impl Failure {
    pub fn code(self) -> &'static str {
        match self {
            Failure::Failed => "failed",
            Failure::Unreachable => "unreachable",
            Failure::Usage => "usage",
        }
    }

    pub fn exit_code(self) -> u8 {
        match self {
            Failure::Failed | Failure::Unreachable => 1,
            Failure::Usage => 2,
        }
    }
}

/// The JSON form of a failure, one line.
pub fn json_line(command: &str, failure: Failure, reason: &str) -> String {
    json!({
        "ok": false,
        "error": failure.code(),
        "command": command,
        "reason": reason,
        "exit_code": failure.exit_code(),
    })
    .to_string()
}

/// Report on stderr (as JSON with `json`) and give the exit code.
pub fn report(command: &str, json: bool, failure: Failure, reason: &str) -> ExitCode {
    if json {
        eprintln!("{}", json_line(command, failure, reason));
    } else if command.is_empty() {
        eprintln!("pulsetrack: {reason}");
    } else {
        eprintln!("pulsetrack {command}: {reason}");
    }
    ExitCode::from(failure.exit_code())
}

/// `report` for the common case: the command failed (exit 1).
pub fn failed(command: &str, json: bool, reason: &str) -> ExitCode {
    report(command, json, Failure::Failed, reason)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_json_form_parses_and_carries_the_reason_verbatim() {
        let line = json_line("sim", Failure::Failed, "scene \"x\" not found\nsee docs");
        assert!(!line.contains('\n'), "one line: {line}");
        let v: serde_json::Value = serde_json::from_str(&line).expect("JSON");
        assert_eq!(v["ok"], false);
        assert_eq!(v["error"], "failed");
        assert_eq!(v["command"], "sim");
        assert_eq!(v["reason"], "scene \"x\" not found\nsee docs");
        assert_eq!(v["exit_code"], 1);
        let v: serde_json::Value =
            serde_json::from_str(&json_line("move", Failure::Usage, "bad")).expect("JSON");
        assert_eq!(
            (v["error"].as_str(), v["exit_code"].as_u64()),
            (Some("usage"), Some(2))
        );
    }
}
