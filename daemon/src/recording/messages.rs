//! The project's own recorded messages as Rust types: the JSON written to a trial file is
//! these types serialized, and each channel's JSON Schema is derived from them (schemars),
//! so a schema cannot drift from what is written.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// `None` for a number that is not finite: JSON has no NaN.
pub fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// One tactile frame with the believed sensor pose at that instant (`/tactile`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TactileSample {
    /// Daemon clock, s (the simulated clock on the sim backend).
    pub t_s: f64,
    /// Frame counter from the array; gaps are dropped frames.
    pub seq: u64,
    /// Normal force per element, N, element 0 first.
    pub force_n: [f64; control::types::ELEMENTS],
    /// Believed sensor centre, tissue frame, m.
    pub sensor_x_m: Option<f64>,
    pub sensor_z_m: Option<f64>,
    /// The loop's own "last motion settled".
    pub settled: bool,
    /// Total contact force, N.
    pub contact_n: Option<f64>,
    /// Present when this frame was given to the trial's tracker: the `settled` it was told
    /// (the loop's settled flag for the motion the supervisor last commanded). Offline replay
    /// feeds exactly these frames with exactly this flag.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracker_settled: Option<bool>,
    /// Where the arm's load said the sensor centre was (the config's `rod`, while powered),
    /// tissue frame, m; absent without a reading (and in recordings made before it existed).
    /// Replay feeds it to the tracker as it was fed live.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loaded_x_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loaded_z_m: Option<f64>,
}

/// Joint state, commands and the believed sensor pose (`/joints`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct JointSample {
    /// Daemon clock, s.
    pub t_s: f64,
    /// Operating state.
    pub state: String,
    pub position_rad: [f64; control::types::JOINTS],
    pub velocity_rad_s: [f64; control::types::JOINTS],
    pub setpoint_rad: [f64; control::types::JOINTS],
    pub torque_nm: [f64; control::types::JOINTS],
    pub sensor_x_m: Option<f64>,
    pub sensor_z_m: Option<f64>,
    pub setpoint_x_m: Option<f64>,
    pub setpoint_z_m: Option<f64>,
    pub depth_m: Option<f64>,
    pub contact_n: Option<f64>,
}

/// Where the simulator truly has the sensor (`/truth`, sim only).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TruthSample {
    /// Daemon clock, s.
    pub t_s: f64,
    /// True centre of the element line, tissue frame, m.
    pub sensor_x_m: f64,
    pub sensor_z_m: f64,
}

/// Who sent a console request (SO_PEERCRED of its connection).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
pub struct ClientId {
    pub uid: u32,
    pub gid: u32,
    /// 0 when the kernel did not say.
    pub pid: i32,
}

/// A console request the supervisor accepted for the operating state (`/events`,
/// `event: "verb"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct VerbRecord {
    /// Always `"verb"`.
    pub event: String,
    pub t_s: f64,
    /// The request's `id`, as the client numbered it.
    pub id: u64,
    pub verb: String,
    /// The verb's arguments, as parsed and range-checked (SI units).
    pub args: Map<String, Value>,
    pub client: ClientId,
}

/// The daemon's answer to a request (`/events`, `event: "reply"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ReplyRecord {
    /// Always `"reply"`.
    pub event: String,
    pub t_s: f64,
    /// The request's `id` (`null` for a line that had none).
    pub id: Option<u64>,
    /// The reply line as sent (`ok`, `error`, `reason`, `state`, results).
    pub reply: Map<String, Value>,
    pub client: ClientId,
}

/// A call into the trial's tracker other than a frame (`/events`, `event: "tracker_input"`),
/// in order with the frames: what offline replay needs to drive a tracker exactly as live.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrackerInputRecord {
    /// Always `"tracker_input"`.
    pub event: String,
    pub t_s: f64,
    pub call: TrackerCall,
}

/// The tracker's methods, with their arguments.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "name", rename_all = "snake_case")]
pub enum TrackerCall {
    Mark,
    Start {
        length_m: Option<f64>,
    },
    Stop,
    TargetUnreachable,
    /// One believed sensor position before the trial's first frame (the approach to the
    /// first placement, tissue frame, m), oldest first.
    Approach {
        x_m: f64,
        z_m: f64,
    },
}

/// Any other event: state changes, detections, faults, trial start and end, labels. Their
/// fields are those of the console's stream events (docs/console-protocol.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct OtherEvent {
    /// `state`, `detection`, `fault`, `trial`, `label`.
    pub event: String,
    pub t_s: f64,
    #[serde(flatten)]
    pub fields: Map<String, Value>,
}

/// The schema of `/events`: one of the records above.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum EventRecord {
    Verb(VerbRecord),
    Reply(ReplyRecord),
    TrackerInput(TrackerInputRecord),
    Other(OtherEvent),
}
