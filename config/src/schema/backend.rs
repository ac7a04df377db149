//! Which backend the daemon drives: the simulator or the real rig. Config alone chooses.

use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

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

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SerialTactile {
    /// A stable device path, e.g. `/dev/serial/by-id/...`.
    pub path: String,
    pub baud: u32,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CanJoints {
    /// SocketCAN interface name, e.g. `can0`.
    pub interface: String,
}

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
                v.at("tactile", |v| {
                    v.check(
                        !h.tactile.path.is_empty(),
                        "path",
                        "must name a serial device",
                    );
                    v.check(h.tactile.baud > 0, "baud", "must be positive");
                });
                v.at("joints", |v| {
                    let name = &h.joints.interface;
                    v.check(
                        !name.is_empty() && name.len() < 16,
                        "interface",
                        format!("must be a network interface name (1-15 bytes), got {name:?}"),
                    );
                });
            }
        }
    }
}
