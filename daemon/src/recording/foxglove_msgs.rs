//! Foxglove's well-known message schemas (foxglove.Log, foxglove.PoseInFrame,
//! foxglove.FrameTransforms, foxglove.SceneUpdate), JSON-encoded, so that Foxglove's and Lichtblick's log, pose and 3D
//! panels show a recording without a plugin. Written here as plain serde types (field names
//! and meanings as in Foxglove's published schemas) because only these few are needed and
//! the `foxglove` SDK crate encodes them as protobuf, not as the JSON the rest of a trial
//! file uses.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A time as Foxglove's JSON schemas spell it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
pub struct Time {
    pub sec: u32,
    pub nsec: u32,
}

impl Time {
    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: u32::try_from(ns / 1_000_000_000).unwrap_or(u32::MAX),
            nsec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// A span of time (`lifetime`: zero keeps an entity until replaced or deleted).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
pub struct Duration {
    pub sec: i32,
    pub nsec: u32,
}

/// foxglove.Log severities.
pub mod level {
    pub const INFO: u8 = 2;
    pub const WARNING: u8 = 3;
    pub const ERROR: u8 = 4;
}

/// foxglove.Log: a log line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Log {
    pub timestamp: Time,
    /// 1 debug, 2 info, 3 warning, 4 error, 5 fatal.
    pub level: u8,
    pub message: String,
    /// What logged it.
    pub name: String,
    pub file: String,
    pub line: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    pub const IDENTITY: Self = Self {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

impl Pose {
    /// A tissue-frame surface point (y = 0), unrotated.
    pub fn at_surface(x_m: f64, z_m: f64) -> Self {
        Self {
            position: Vector3 {
                x: x_m,
                y: 0.0,
                z: z_m,
            },
            orientation: Quaternion::IDENTITY,
        }
    }
}

/// foxglove.FrameTransform: `child_frame_id` as seen from `parent_frame_id`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FrameTransform {
    pub timestamp: Time,
    pub parent_frame_id: String,
    pub child_frame_id: String,
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// foxglove.FrameTransforms: several transforms at once.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FrameTransforms {
    pub transforms: Vec<FrameTransform>,
}

/// foxglove.PoseInFrame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PoseInFrame {
    pub timestamp: Time,
    pub frame_id: String,
    pub pose: Pose,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SpherePrimitive {
    pub pose: Pose,
    /// Diameters along x, y, z, m.
    pub size: Vector3,
    pub color: Color,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct LinePrimitive {
    /// 0 line strip, 1 line loop, 2 line list.
    #[serde(rename = "type")]
    pub kind: u8,
    pub pose: Pose,
    /// Width, m (pixels if scale_invariant).
    pub thickness: f64,
    pub scale_invariant: bool,
    pub points: Vec<Vector3>,
    pub color: Color,
    pub colors: Vec<Color>,
    pub indices: Vec<u32>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct KeyValuePair {
    pub key: String,
    pub value: String,
}

/// One entity of a scene; the primitive lists foxglove.SceneEntity has and this project does
/// not draw are written empty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: String,
    pub id: String,
    pub lifetime: Duration,
    pub frame_locked: bool,
    pub metadata: Vec<KeyValuePair>,
    pub arrows: Vec<serde_json::Value>,
    pub cubes: Vec<serde_json::Value>,
    pub spheres: Vec<SpherePrimitive>,
    pub cylinders: Vec<serde_json::Value>,
    pub lines: Vec<LinePrimitive>,
    pub triangles: Vec<serde_json::Value>,
    pub texts: Vec<serde_json::Value>,
    pub models: Vec<serde_json::Value>,
}

impl SceneEntity {
    pub fn new(timestamp: Time, frame_id: &str, id: &str) -> Self {
        Self {
            timestamp,
            frame_id: frame_id.into(),
            id: id.into(),
            lifetime: Duration::default(),
            frame_locked: false,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines: Vec::new(),
            triangles: Vec::new(),
            texts: Vec::new(),
            models: Vec::new(),
        }
    }
}

/// foxglove.SceneUpdate: entities to add or replace (by id).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SceneUpdate {
    pub deletions: Vec<serde_json::Value>,
    pub entities: Vec<SceneEntity>,
}
