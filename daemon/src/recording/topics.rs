//! The channels of a trial recording and their JSON Schemas (MCAP `jsonschema` encoding,
//! JSON messages). The project's own schemas are derived from the Rust types written
//! ([`crate::recording::messages`]); poses, the scene and the log use Foxglove's well-known
//! schemas ([`crate::recording::foxglove_msgs`]) so Foxglove's panels show them as they are.

use std::sync::OnceLock;

use schemars::JsonSchema;

use crate::recording::foxglove_msgs as fox;
use crate::recording::messages as msg;

/// A recorded channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    /// Joint state, commands and the believed sensor pose, every `joint_decimation` cycles.
    Joints,
    /// Every tactile frame with the believed sensor pose at that instant.
    Tactile,
    /// Operating-state changes, requests and replies, tracker inputs and detections, faults.
    Events,
    /// Simulator ground truth (sim backend only).
    Truth,
    /// The same state changes, requests, detections and faults as log lines (foxglove.Log).
    Log,
    /// The believed sensor pose (foxglove.PoseInFrame, tissue frame).
    SensorBelieved,
    /// The true sensor pose, sim only (foxglove.PoseInFrame, tissue frame).
    SensorTrue,
    /// The artery: located points and, in sim, the true path (foxglove.SceneUpdate).
    Artery,
    /// The arm as a frame tree from its encoders: base -> tissue, gimbal, pivot; tissue ->
    /// sensor (foxglove.FrameTransforms), every `joint_decimation` cycles.
    Transforms,
}

/// The frame every pose and scene entity is given in.
pub const TISSUE_FRAME: &str = "tissue";

impl Topic {
    pub const ALL: [Topic; 9] = [
        Topic::Joints,
        Topic::Tactile,
        Topic::Events,
        Topic::Truth,
        Topic::Log,
        Topic::SensorBelieved,
        Topic::SensorTrue,
        Topic::Artery,
        Topic::Transforms,
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Topic::Joints => "/joints",
            Topic::Tactile => "/tactile",
            Topic::Events => "/events",
            Topic::Truth => "/truth",
            Topic::Log => "/log",
            Topic::SensorBelieved => "/sensor/believed",
            Topic::SensorTrue => "/sensor/true",
            Topic::Artery => "/artery",
            Topic::Transforms => "/tf",
        }
    }

    pub fn schema_name(&self) -> &'static str {
        match self {
            Topic::Joints => "pulsetrack.JointSample",
            Topic::Tactile => "pulsetrack.TactileFrame",
            Topic::Events => "pulsetrack.Event",
            Topic::Truth => "pulsetrack.Truth",
            Topic::Log => "foxglove.Log",
            Topic::SensorBelieved | Topic::SensorTrue => "foxglove.PoseInFrame",
            Topic::Artery => "foxglove.SceneUpdate",
            Topic::Transforms => "foxglove.FrameTransforms",
        }
    }

    pub fn from_name(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The JSON Schema of this channel's messages, derived once from its Rust type.
    pub fn schema(&self) -> &'static str {
        static SCHEMAS: OnceLock<Vec<String>> = OnceLock::new();
        let all = SCHEMAS.get_or_init(|| Topic::ALL.iter().map(|t| t.derive_schema()).collect());
        let i = Topic::ALL.iter().position(|t| t == self).unwrap_or(0);
        all.get(i).map(String::as_str).unwrap_or("{}")
    }

    fn derive_schema(&self) -> String {
        match self {
            Topic::Joints => schema_of::<msg::JointSample>(self.schema_name()),
            Topic::Tactile => schema_of::<msg::TactileSample>(self.schema_name()),
            Topic::Events => schema_of::<msg::EventRecord>(self.schema_name()),
            Topic::Truth => schema_of::<msg::TruthSample>(self.schema_name()),
            Topic::Log => schema_of::<fox::Log>(self.schema_name()),
            Topic::SensorBelieved | Topic::SensorTrue => {
                schema_of::<fox::PoseInFrame>(self.schema_name())
            }
            Topic::Artery => schema_of::<fox::SceneUpdate>(self.schema_name()),
            Topic::Transforms => schema_of::<fox::FrameTransforms>(self.schema_name()),
        }
    }
}

/// The draft 2020-12 schema of `T`, titled with the schema's name.
pub fn schema_of<T: JsonSchema>(title: &str) -> String {
    let mut schema = schemars::schema_for!(T);
    schema.insert("title".into(), title.into());
    serde_json::to_string(&schema).unwrap_or_else(|_| "{}".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemas_are_json_and_names_round_trip() {
        for t in Topic::ALL {
            let v: serde_json::Value =
                serde_json::from_str(t.schema()).unwrap_or_else(|e| panic!("{}: {e}", t.name()));
            assert_eq!(v["title"], t.schema_name());
            assert_eq!(
                v["$schema"],
                "https://json-schema.org/draft/2020-12/schema",
                "{}",
                t.name()
            );
            assert_eq!(Topic::from_name(t.name()), Some(t));
        }
    }

    #[test]
    fn derived_schemas_describe_the_fields_written() {
        let tactile: serde_json::Value =
            serde_json::from_str(Topic::Tactile.schema()).expect("json");
        for field in ["t_s", "seq", "force_n", "settled", "tracker_settled"] {
            assert!(
                tactile["properties"].get(field).is_some(),
                "{field} missing from {tactile}"
            );
        }
        let log: serde_json::Value = serde_json::from_str(Topic::Log.schema()).expect("json");
        for field in ["timestamp", "level", "message", "name", "file", "line"] {
            assert!(log["properties"].get(field).is_some(), "{field}");
        }
    }
}
