//! Which backend the daemon drives: the simulator or the real rig. Config alone chooses.

use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

// Read once at start-up; the size of the hardware variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Backend {
    /// The physical simulator: a scene file, a random seed, a clock.
    Sim(SimBackend),
    /// The real rig: the tactile array over serial and the Phantom's joints over CAN.
    Hardware(HardwareBackend),
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimBackend {
    /// Scene file, relative to this config file, or the name of a shipped scene
    /// (`seed-arc-145.ron`).
    pub scene: String,
    /// Random seed: the same seed gives the same trial.
    #[serde(default)]
    pub seed: u64,
    /// Simulated seconds per wall-clock second: 1.0 runs in real time; larger runs the
    /// simulated clock faster (tests use this instead of waiting).
    #[serde(default = "one")]
    pub time_scale: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HardwareBackend {
    pub tactile: SerialTactile,
    pub joints: CanJoints,
}

/// The tactile array's serial link (docs/protocols/tactile-serial.md). Every field but
/// `path` has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SerialTactile {
    /// A stable device path, e.g. `/dev/serial/by-id/...` (not `/dev/ttyUSB0`, which can
    /// change on replug).
    pub path: String,
    /// Line rate, bit/s (a 100 Hz, 10-channel stream needs about 5 kbit/s).
    pub baud: u32,
    /// First wait before reopening the port after an unplug or a failed open, s; doubles on
    /// each failure up to `reconnect_max_s`.
    pub reconnect_initial_s: f64,
    pub reconnect_max_s: f64,
    /// No valid frame for this long and the stream is reported stale (and the device is
    /// asked to stream again), s.
    pub stale_after_s: f64,
    /// Wait this long for the device's answer to a configure message before asking again, s.
    pub handshake_timeout_s: f64,
    /// Frames with any element beyond ±this are out of range and dropped, N.
    pub max_force_n: f64,
    /// Frames buffered between the serial task and the control loop; when full the oldest
    /// is dropped (and counted).
    pub queue_frames: usize,
}

impl Default for SerialTactile {
    fn default() -> Self {
        Self {
            path: String::new(),
            baud: 115_200,
            reconnect_initial_s: 0.1,
            reconnect_max_s: 2.0,
            stale_after_s: 0.1,
            handshake_timeout_s: 0.5,
            max_force_n: 3.0,
            queue_frames: 64,
        }
    }
}

/// How the host reaches the CAN bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum CanAdapter {
    /// A SocketCAN network interface (`can0`), brought up with its bitrate by
    /// `ip link set can0 up type can bitrate 1000000`.
    SocketCan { interface: String },
    /// A Lawicel serial-line CAN adapter (slcan) on a tty, driven directly.
    Slcan {
        /// Stable tty path, e.g. `/dev/serial/by-id/usb-...-if00`.
        path: String,
        /// Serial line rate to the adapter, bit/s (USB adapters ignore it).
        baud: u32,
        /// CAN bitrate the adapter opens the bus at, bit/s (10k..1M, a Lawicel `S` code).
        bitrate_bps: u32,
    },
}

/// The Phantom's three joint amplifiers on CAN (docs/protocols/phantom-can.md). Per-joint
/// arrays are in joint order θ1, θ2, θ3.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CanJoints {
    pub adapter: CanAdapter,
    /// CAN node id of each joint's amplifier (1..=127).
    pub node_ids: [u8; 3],
    /// The host's node id, for its heartbeat (1..=127, distinct from the amplifiers).
    pub host_node_id: u8,
    /// Encoder counts per motor revolution.
    pub counts_per_rev: [u32; 3],
    /// Capstan reduction, motor turns per joint turn.
    pub capstan_ratio: [f64; 3],
    /// +1 if a positive encoder count (and positive motor torque) is a positive joint
    /// angle (torque), -1 if reversed.
    pub direction: [f64; 3],
    /// Joint angle at encoder count 0 (the pose the arm is powered up in), rad.
    pub zero_offset_rad: [f64; 3],
    /// Largest motor torque ever commanded, N·m (the Phantom's motors: 0.0286 continuous).
    pub max_motor_torque_nm: [f64; 3],
    /// Any joint's feedback older than this while enabled is a fault, s.
    pub feedback_timeout_s: f64,
    /// Period of the host heartbeat the amplifiers watch, s.
    pub heartbeat_period_s: f64,
    /// Amplifiers must report enabled within this after `enable`, s.
    pub enable_timeout_s: f64,
    /// Time constant of the low-pass on the encoder-difference velocity, s.
    pub velocity_filter_s: f64,
    /// Feedback implying a faster joint than this is an encoder glitch and is dropped,
    /// rad/s.
    pub max_joint_speed_rad_s: f64,
}

impl Default for CanJoints {
    fn default() -> Self {
        Self {
            adapter: CanAdapter::SocketCan {
                interface: "can0".to_string(),
            },
            node_ids: [1, 2, 3],
            host_node_id: 100,
            counts_per_rev: [1024; 3],
            capstan_ratio: [13.3, 11.2, 11.2],
            direction: [1.0; 3],
            zero_offset_rad: [0.0; 3],
            max_motor_torque_nm: [0.0286; 3],
            feedback_timeout_s: 0.005,
            heartbeat_period_s: 0.05,
            enable_timeout_s: 0.5,
            velocity_filter_s: 0.002,
            max_joint_speed_rad_s: 20.0,
        }
    }
}

impl Validate for SerialTactile {
    fn validate(&self, v: &mut Validator) {
        v.check(!self.path.is_empty(), "path", "must name a serial device");
        v.check(self.baud > 0, "baud", "must be positive");
        v.positive("reconnect_initial_s", self.reconnect_initial_s);
        v.positive("reconnect_max_s", self.reconnect_max_s);
        v.check(
            self.reconnect_max_s >= self.reconnect_initial_s,
            "reconnect_max_s",
            "must not be below reconnect_initial_s",
        );
        v.positive("stale_after_s", self.stale_after_s);
        v.positive("handshake_timeout_s", self.handshake_timeout_s);
        // Beyond ±3.2767 N the wire format cannot represent a force at all.
        v.in_range("max_force_n", self.max_force_n, 1e-3, 3.2767);
        v.check(
            (1..=100_000).contains(&self.queue_frames),
            "queue_frames",
            format!("must be between 1 and 100000, got {}", self.queue_frames),
        );
    }
}

impl Validate for CanJoints {
    fn validate(&self, v: &mut Validator) {
        match &self.adapter {
            CanAdapter::SocketCan { interface } => v.at("adapter", |v| {
                v.check(
                    !interface.is_empty() && interface.len() < 16 && !interface.contains('/'),
                    "interface",
                    format!("must be a network interface name (1-15 bytes), got {interface:?}"),
                );
            }),
            CanAdapter::Slcan {
                path,
                baud,
                bitrate_bps,
            } => v.at("adapter", |v| {
                v.check(!path.is_empty(), "path", "must name a serial device");
                v.check(*baud > 0, "baud", "must be positive");
                v.check(
                    SLCAN_BITRATES.contains(bitrate_bps),
                    "bitrate_bps",
                    format!("must be one of {SLCAN_BITRATES:?}, got {bitrate_bps}"),
                );
            }),
        }
        for (i, &id) in self.node_ids.iter().enumerate() {
            v.check(
                (1..=127).contains(&id),
                &format!("node_ids[{i}]"),
                format!("must be a CAN node id 1..=127, got {id}"),
            );
            if self.node_ids[..i].contains(&id) {
                v.problem(
                    &format!("node_ids[{i}]"),
                    format!("node id {id} is used twice"),
                );
            }
        }
        v.check(
            (1..=127).contains(&self.host_node_id) && !self.node_ids.contains(&self.host_node_id),
            "host_node_id",
            format!(
                "must be 1..=127 and differ from the amplifiers' ids, got {}",
                self.host_node_id
            ),
        );
        for (i, &c) in self.counts_per_rev.iter().enumerate() {
            v.check(c > 0, &format!("counts_per_rev[{i}]"), "must be positive");
        }
        v.all_positive("capstan_ratio", &self.capstan_ratio);
        for (i, &d) in self.direction.iter().enumerate() {
            v.check(
                d == 1.0 || d == -1.0,
                &format!("direction[{i}]"),
                format!("must be 1 or -1, got {d}"),
            );
        }
        v.all_finite("zero_offset_rad", &self.zero_offset_rad);
        for (i, &t) in self.max_motor_torque_nm.iter().enumerate() {
            // The command field holds at most ±0.32767 N·m.
            v.in_range(&format!("max_motor_torque_nm[{i}]"), t, 1e-5, 0.32767);
        }
        v.positive("feedback_timeout_s", self.feedback_timeout_s);
        v.positive("heartbeat_period_s", self.heartbeat_period_s);
        v.positive("enable_timeout_s", self.enable_timeout_s);
        v.positive("velocity_filter_s", self.velocity_filter_s);
        v.positive("max_joint_speed_rad_s", self.max_joint_speed_rad_s);
    }
}

/// Bitrates a Lawicel adapter can open the bus at (`S0`..`S8`).
pub const SLCAN_BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

impl Validate for Backend {
    fn validate(&self, v: &mut Validator) {
        match self {
            Backend::Sim(s) => {
                v.check(
                    !s.scene.trim().is_empty(),
                    "scene",
                    "must name a scene file",
                );
                v.in_range("time_scale", s.time_scale, 0.01, 1.0e6);
            }
            Backend::Hardware(h) => {
                v.section("tactile", &h.tactile);
                v.section("joints", &h.joints);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::{Config, load_str, shipped::LAB_CONFIG};

    fn lab_with(from: &str, to: &str) -> String {
        let (_, text) = LAB_CONFIG;
        assert!(text.contains(from), "lab.ron has no {from:?}");
        text.replace(from, to)
    }

    fn problems(text: &str) -> String {
        match load_str::<Config>("lab.ron", text) {
            Ok(_) => panic!("accepted"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn hardware_errors_name_the_field_and_line() {
        let e = problems(&lab_with("node_ids: (1, 2, 3)", "node_ids: (1, 2, 2)"));
        assert!(
            e.contains("field `backend.joints.node_ids[2]`: node id 2 is used twice"),
            "{e}"
        );
        assert!(e.starts_with("lab.ron:"), "{e}");

        let e = problems(&lab_with("max_force_n: 3.0", "max_force_n: 5.0"));
        assert!(e.contains("field `backend.tactile.max_force_n`"), "{e}");

        let e = problems(&lab_with(
            "direction: (1.0, 1.0, 1.0)",
            "direction: (1.0, 0.5, 1.0)",
        ));
        assert!(
            e.contains("field `backend.joints.direction[1]`: must be 1 or -1"),
            "{e}"
        );

        let e = problems(&lab_with(
            "max_motor_torque_nm: (0.0286, 0.0286, 0.0286)",
            "max_motor_torque_nm: (0.0286, 0.0286, 0.5)",
        ));
        assert!(
            e.contains("field `backend.joints.max_motor_torque_nm[2]`"),
            "{e}"
        );

        let e = problems(&lab_with(
            "adapter: SocketCan(interface: \"can0\")",
            "adapter: SocketCan(interface: \"\")",
        ));
        assert!(e.contains("backend.joints.adapter.interface"), "{e}");

        let e = problems(&lab_with(
            "adapter: SocketCan(interface: \"can0\")",
            "adapter: Slcan(path: \"/dev/ttyACM0\", baud: 115200, bitrate_bps: 300000)",
        ));
        assert!(e.contains("backend.joints.adapter.bitrate_bps"), "{e}");

        let e = problems(&lab_with("reconnect_max_s: 2.0", "reconnect_max_s: 0.01"));
        assert!(e.contains("backend.tactile.reconnect_max_s"), "{e}");

        let e = problems(&lab_with(
            "baud: 115200,\n            reconnect",
            "bauds: 115200,\n            reconnect",
        ));
        assert!(e.contains("bauds"), "{e}");
    }

    #[test]
    fn an_slcan_adapter_is_accepted() {
        let text = lab_with(
            "adapter: SocketCan(interface: \"can0\")",
            "adapter: Slcan(path: \"/dev/serial/by-id/usb-canable-if00\", baud: 115200, bitrate_bps: 1000000)",
        );
        let c: Config = load_str("lab.ron", &text).unwrap_or_else(|e| panic!("{e}"));
        let crate::schema::Backend::Hardware(hw) = c.backend else {
            panic!("lab.ron selects hardware")
        };
        assert!(matches!(
            hw.joints.adapter,
            crate::schema::CanAdapter::Slcan {
                bitrate_bps: 1_000_000,
                ..
            }
        ));
    }
}
