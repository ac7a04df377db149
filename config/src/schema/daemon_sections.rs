//! The daemon's own sections: safety limits, manual operation, the real-time loop, the
//! console socket and trial recording.

use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetySection {
    /// Joint data older than this faults the loop, s.
    pub joint_stale_s: f64,
    /// Tactile data older than this faults an enabled arm (contact force is then unknown), s.
    pub tactile_stale_s: f64,
    /// Largest total contact force the sensor may report, N.
    pub contact_force_max_n: f64,
    /// Seconds of states and commands kept in memory and dumped on a fault.
    pub flight_recorder_s: f64,
    /// Allowed sensor-centre region on the tissue surface, tissue frame `x` then `z`,
    /// `[min, max]`, m. Targets outside are refused; a setpoint outside faults.
    pub workspace_x_m: [f64; 2],
    pub workspace_z_m: [f64; 2],
    /// Distance between the commanded and the believed sensor centre that trips the loop, m.
    pub max_sensor_error_m: f64,
    /// Consecutive missed deadlines that fault a loop driving real hardware (the simulator's
    /// clock cannot fall behind, so there misses are only counted).
    pub max_consecutive_overruns: u32,
}

impl Default for SafetySection {
    fn default() -> Self {
        Self {
            joint_stale_s: 0.01,
            tactile_stale_s: 0.1,
            contact_force_max_n: 10.0,
            flight_recorder_s: 5.0,
            workspace_x_m: [-0.2, 0.2],
            workspace_z_m: [-0.2, 0.2],
            max_sensor_error_m: 0.01,
            max_consecutive_overruns: 20,
        }
    }
}

fn range(v: &mut Validator, field: &str, r: [f64; 2]) {
    v.all_finite(field, &r);
    v.check(
        r[0] < r[1],
        field,
        format!(
            "must be [min, max] with min < max, got [{}, {}]",
            r[0], r[1]
        ),
    );
}

impl Validate for SafetySection {
    fn validate(&self, v: &mut Validator) {
        v.positive("joint_stale_s", self.joint_stale_s);
        v.positive("tactile_stale_s", self.tactile_stale_s);
        v.positive("contact_force_max_n", self.contact_force_max_n);
        v.in_range("flight_recorder_s", self.flight_recorder_s, 0.0, 600.0);
        range(v, "workspace_x_m", self.workspace_x_m);
        range(v, "workspace_z_m", self.workspace_z_m);
        v.positive("max_sensor_error_m", self.max_sensor_error_m);
        v.check(
            self.max_consecutive_overruns >= 1,
            "max_consecutive_overruns",
            "must be at least 1",
        );
    }
}

/// Manual operation from the console: home, jog and move.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OperationSection {
    /// Where `home` takes the sensor centre, tissue frame `[x, z]`, m.
    pub home_m: [f64; 2],
    /// Speed of `home` and of `move` when the request names none, m/s.
    pub move_speed_m_s: f64,
    /// Longest single `jog`, m.
    pub max_jog_m: f64,
}

impl Default for OperationSection {
    fn default() -> Self {
        Self {
            home_m: [0.0, 0.0],
            move_speed_m_s: 0.01,
            max_jog_m: 0.01,
        }
    }
}

impl Validate for OperationSection {
    fn validate(&self, v: &mut Validator) {
        v.all_finite("home_m", &self.home_m);
        v.positive("move_speed_m_s", self.move_speed_m_s);
        v.positive("max_jog_m", self.max_jog_m);
    }
}

/// The 1 kHz loop's thread.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RealtimeSection {
    /// SCHED_FIFO priority asked for (1-99); refused without CAP_SYS_NICE / LimitRTPRIO, in
    /// which case the loop runs at normal priority with one warning.
    pub priority: u8,
    /// Lock the daemon's memory (mlockall) so the loop never page-faults.
    pub lock_memory: bool,
    /// At most one overrun summary in the log per this many seconds.
    pub overrun_report_s: f64,
}

impl Default for RealtimeSection {
    fn default() -> Self {
        Self {
            priority: 80,
            lock_memory: true,
            overrun_report_s: 10.0,
        }
    }
}

impl Validate for RealtimeSection {
    fn validate(&self, v: &mut Validator) {
        v.check(
            (1..=99).contains(&self.priority),
            "priority",
            format!("must be 1-99, got {}", self.priority),
        );
        v.in_range("overrun_report_s", self.overrun_report_s, 0.1, 3600.0);
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ConsoleSection {
    /// Unix socket the console listens on (created with mode 0660).
    pub socket_path: String,
    /// Peer user ids allowed to connect (the daemon's own uid and root always are).
    pub allowed_uids: Vec<u32>,
    /// Peer group ids allowed to connect.
    pub allowed_gids: Vec<u32>,
    /// Longest request line accepted, bytes.
    pub max_line_bytes: usize,
    /// Requests per second one client may send before its requests are refused.
    pub max_requests_per_s: f64,
    /// Clients connected at once. One more connection is always kept free for `estop` and
    /// `status` only, so a console full of idle clients never locks out an emergency stop.
    pub max_clients: usize,
    /// A client that sends no request for this long, and subscribes to nothing, is
    /// disconnected (told why), s.
    pub idle_timeout_s: f64,
    /// The user the daemon runs as (for example `pulsetrack` under the shipped systemd
    /// unit). The `pulsetrack` console tool talks only to a socket whose owner is root,
    /// itself, or this user, so a socket swapped by someone else is never trusted.
    pub daemon_user: Option<String>,
    /// Accept the `debug` verb (fault injection for tests; see docs/console-protocol.md).
    pub debug_hooks: bool,
}

impl Default for ConsoleSection {
    fn default() -> Self {
        Self {
            socket_path: "/run/pulsetrack/console.sock".to_string(),
            allowed_uids: Vec::new(),
            allowed_gids: Vec::new(),
            max_line_bytes: 64 * 1024,
            max_requests_per_s: 200.0,
            max_clients: 16,
            idle_timeout_s: 300.0,
            daemon_user: None,
            debug_hooks: false,
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
        v.in_range("max_requests_per_s", self.max_requests_per_s, 1.0, 1.0e6);
        v.check(
            (1..=1024).contains(&self.max_clients),
            "max_clients",
            "must be 1-1024",
        );
        v.in_range("idle_timeout_s", self.idle_timeout_s, 0.1, 86_400.0);
        if let Some(u) = &self.daemon_user {
            v.check(
                !u.is_empty() && !u.contains(['/', ':', '\n']),
                "daemon_user",
                "must be a user name",
            );
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordingSection {
    /// Directory where each trial's recording and summary are written.
    pub dir: String,
    /// Joint states are recorded every this many control cycles.
    pub joint_decimation: u32,
    /// Buffered records reach the kernel at least this often, s (what a kill -9 can lose).
    pub flush_interval_s: f64,
    /// Buffered records reach the disk at least this often, s (what a power cut can lose).
    /// Acknowledged events are always on disk before the acknowledgement.
    pub fsync_interval_s: f64,
    /// A trial does not start with less free space than this in `dir`, bytes (about 4 MB
    /// a trial minute; a write that fails anyway stops the trial with `recording_failed`).
    pub min_free_bytes: u64,
}

impl Default for RecordingSection {
    fn default() -> Self {
        Self {
            dir: "/var/lib/pulsetrack/trials".to_string(),
            joint_decimation: 10,
            flush_interval_s: 0.1,
            fsync_interval_s: 1.0,
            min_free_bytes: 64 * 1024 * 1024,
        }
    }
}

impl Validate for RecordingSection {
    fn validate(&self, v: &mut Validator) {
        v.check(!self.dir.is_empty(), "dir", "must name a directory");
        v.check(
            self.joint_decimation >= 1,
            "joint_decimation",
            "must be at least 1",
        );
        v.in_range("flush_interval_s", self.flush_interval_s, 0.001, 60.0);
        v.in_range("fsync_interval_s", self.fsync_interval_s, 0.001, 3600.0);
    }
}
