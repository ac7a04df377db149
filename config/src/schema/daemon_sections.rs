//! Safety limits, the console socket and trial recording.

use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetySection {
    /// Joint data older than this faults the loop, s.
    pub joint_stale_s: f64,
    /// Tactile data older than this faults tracking, s.
    pub tactile_stale_s: f64,
    /// Largest total contact force the sensor may report, N.
    pub contact_force_max_n: f64,
    /// Seconds of states and commands kept in memory and dumped on a fault.
    pub flight_recorder_s: f64,
}

impl Default for SafetySection {
    fn default() -> Self {
        Self {
            joint_stale_s: 0.01,
            tactile_stale_s: 0.1,
            contact_force_max_n: 10.0,
            flight_recorder_s: 5.0,
        }
    }
}

impl Validate for SafetySection {
    fn validate(&self, v: &mut Validator) {
        v.positive("joint_stale_s", self.joint_stale_s);
        v.positive("tactile_stale_s", self.tactile_stale_s);
        v.positive("contact_force_max_n", self.contact_force_max_n);
        v.in_range("flight_recorder_s", self.flight_recorder_s, 0.0, 600.0);
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ConsoleSection {
    /// Unix socket the console listens on.
    pub socket_path: String,
    /// Peer user ids allowed to connect (the daemon's own uid always is).
    pub allowed_uids: Vec<u32>,
    /// Peer group ids allowed to connect.
    pub allowed_gids: Vec<u32>,
    /// Longest request line accepted, bytes.
    pub max_line_bytes: usize,
}

impl Default for ConsoleSection {
    fn default() -> Self {
        Self {
            socket_path: "/run/pulsetrack/console.sock".to_string(),
            allowed_uids: Vec::new(),
            allowed_gids: Vec::new(),
            max_line_bytes: 64 * 1024,
        }
    }
}

impl Validate for ConsoleSection {
    fn validate(&self, v: &mut Validator) {
        v.check(
            !self.socket_path.is_empty(),
            "socket_path",
            "must name a socket path",
        );
        // sockaddr_un holds 108 bytes including the terminator.
        v.check(
            self.socket_path.len() < 108,
            "socket_path",
            format!(
                "is {} bytes; a Unix socket path must be under 108",
                self.socket_path.len()
            ),
        );
        v.check(
            (256..=16 * 1024 * 1024).contains(&self.max_line_bytes),
            "max_line_bytes",
            "must be between 256 B and 16 MiB",
        );
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordingSection {
    /// Directory where each trial's recording and summary are written.
    pub dir: String,
}

impl Default for RecordingSection {
    fn default() -> Self {
        Self {
            dir: "/var/lib/pulsetrack/trials".to_string(),
        }
    }
}

impl Validate for RecordingSection {
    fn validate(&self, v: &mut Validator) {
        v.check(!self.dir.is_empty(), "dir", "must name a directory");
    }
}
