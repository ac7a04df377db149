//! The channels of the live view: every channel of a trial recording (same names, schemas
//! and JSON), and four that only the live view has.

use std::sync::OnceLock;

use crate::live::messages as live_msg;
use crate::recording::topics::{Topic, schema_of};

/// A live channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LiveTopic {
    /// A channel of the recording, as recorded.
    Recorded(Topic),
    /// Every tactile frame through the tracker's band-pass.
    TactileBandPassed,
    /// The pulse: the tracker's period and each element's band-passed swing.
    Pulse,
    /// Loop timing and what was dropped on the way to the live view.
    Loop,
    /// The operating state, on change and four times a second.
    State,
}

impl LiveTopic {
    pub const ALL: [LiveTopic; 13] = [
        LiveTopic::Recorded(Topic::Joints),
        LiveTopic::Recorded(Topic::Tactile),
        LiveTopic::Recorded(Topic::Events),
        LiveTopic::Recorded(Topic::Truth),
        LiveTopic::Recorded(Topic::Log),
        LiveTopic::Recorded(Topic::SensorBelieved),
        LiveTopic::Recorded(Topic::SensorTrue),
        LiveTopic::Recorded(Topic::Artery),
        LiveTopic::Recorded(Topic::Transforms),
        LiveTopic::TactileBandPassed,
        LiveTopic::Pulse,
        LiveTopic::Loop,
        LiveTopic::State,
    ];

    /// Position in [`LiveTopic::ALL`] (a bit in the publisher's "subscribed" mask).
    pub fn index(&self) -> usize {
        LiveTopic::ALL.iter().position(|t| t == self).unwrap_or(0)
    }

    pub fn name(&self) -> &'static str {
        match self {
            LiveTopic::Recorded(t) => t.name(),
            LiveTopic::TactileBandPassed => "/tactile/bandpassed",
            LiveTopic::Pulse => "/pulse",
            LiveTopic::Loop => "/loop",
            LiveTopic::State => "/state",
        }
    }

    pub fn schema_name(&self) -> &'static str {
        match self {
            LiveTopic::Recorded(t) => t.schema_name(),
            LiveTopic::TactileBandPassed => "pulsetrack.BandPassedFrame",
            LiveTopic::Pulse => "pulsetrack.Pulse",
            LiveTopic::Loop => "pulsetrack.LoopTiming",
            LiveTopic::State => "pulsetrack.State",
        }
    }

    /// The JSON Schema of this channel's messages (the recording's for recorded channels).
    pub fn schema(&self) -> &'static str {
        static OWN: OnceLock<[String; 4]> = OnceLock::new();
        let own = OWN.get_or_init(|| {
            [
                schema_of::<live_msg::BandPassedFrame>(LiveTopic::TactileBandPassed.schema_name()),
                schema_of::<live_msg::PulseSample>(LiveTopic::Pulse.schema_name()),
                schema_of::<live_msg::LoopTiming>(LiveTopic::Loop.schema_name()),
                schema_of::<live_msg::LiveState>(LiveTopic::State.schema_name()),
            ]
        });
        match self {
            LiveTopic::Recorded(t) => t.schema(),
            LiveTopic::TactileBandPassed => &own[0],
            LiveTopic::Pulse => &own[1],
            LiveTopic::Loop => &own[2],
            LiveTopic::State => &own[3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_channel_has_a_distinct_name_a_titled_schema_and_its_own_bit() {
        let mut names = std::collections::BTreeSet::new();
        for (i, t) in LiveTopic::ALL.iter().enumerate() {
            assert!(names.insert(t.name()), "{} twice", t.name());
            assert_eq!(t.index(), i);
            let v: serde_json::Value = serde_json::from_str(t.schema()).expect("json");
            assert_eq!(v["title"], t.schema_name());
        }
        assert!(LiveTopic::ALL.len() <= 64);
        for t in Topic::ALL {
            assert!(LiveTopic::ALL.contains(&LiveTopic::Recorded(t)), "{t:?}");
        }
    }
}
