//! The channels of a trial recording and their JSON schemas (MCAP `jsonschema` encoding, JSON
//! messages), so Foxglove and PlotJuggler can plot every field without a plugin.

/// A recorded channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    /// Joint state, commands and the believed sensor pose, every `joint_decimation` cycles.
    Joints,
    /// Every tactile frame with the believed sensor pose at that instant.
    Tactile,
    /// Operating-state changes, accepted verbs, tracker detections, faults.
    Events,
    /// Simulator ground truth (sim backend only).
    Truth,
}

impl Topic {
    pub const ALL: [Topic; 4] = [Topic::Joints, Topic::Tactile, Topic::Events, Topic::Truth];

    pub fn name(&self) -> &'static str {
        match self {
            Topic::Joints => "/joints",
            Topic::Tactile => "/tactile",
            Topic::Events => "/events",
            Topic::Truth => "/truth",
        }
    }

    pub fn schema_name(&self) -> &'static str {
        match self {
            Topic::Joints => "pulsetrack.JointSample",
            Topic::Tactile => "pulsetrack.TactileFrame",
            Topic::Events => "pulsetrack.Event",
            Topic::Truth => "pulsetrack.Truth",
        }
    }

    pub fn from_name(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The JSON schema of this channel's messages.
    pub fn schema(&self) -> &'static str {
        match self {
            Topic::Joints => {
                r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"pulsetrack.JointSample","type":"object","properties":{"t_s":{"type":"number","description":"daemon clock, s"},"state":{"type":"string"},"position_rad":{"type":"array","items":{"type":"number"},"minItems":3,"maxItems":3},"velocity_rad_s":{"type":"array","items":{"type":"number"},"minItems":3,"maxItems":3},"setpoint_rad":{"type":"array","items":{"type":"number"},"minItems":3,"maxItems":3},"torque_nm":{"type":"array","items":{"type":"number"},"minItems":3,"maxItems":3},"sensor_x_m":{"type":"number"},"sensor_z_m":{"type":"number"},"setpoint_x_m":{"type":"number"},"setpoint_z_m":{"type":"number"},"depth_m":{"type":["number","null"]},"contact_n":{"type":["number","null"]}},"required":["t_s","position_rad","velocity_rad_s","torque_nm"]}"#
            }
            Topic::Tactile => {
                r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"pulsetrack.TactileFrame","type":"object","properties":{"t_s":{"type":"number","description":"daemon clock, s"},"seq":{"type":"integer"},"force_n":{"type":"array","items":{"type":"number"},"minItems":10,"maxItems":10},"sensor_x_m":{"type":"number"},"sensor_z_m":{"type":"number"},"settled":{"type":"boolean"},"contact_n":{"type":"number"}},"required":["t_s","seq","force_n"]}"#
            }
            Topic::Events => {
                r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"pulsetrack.Event","type":"object","properties":{"t_s":{"type":"number","description":"daemon clock, s"},"event":{"type":"string","description":"state, verb, detection, fault, trial"}},"required":["t_s","event"],"additionalProperties":true}"#
            }
            Topic::Truth => {
                r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"pulsetrack.Truth","type":"object","properties":{"t_s":{"type":"number"},"sensor_x_m":{"type":"number","description":"true sensor centre, tissue frame"},"sensor_z_m":{"type":"number"}},"required":["t_s","sensor_x_m","sensor_z_m"]}"#
            }
        }
    }
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
            assert_eq!(Topic::from_name(t.name()), Some(t));
        }
    }
}
