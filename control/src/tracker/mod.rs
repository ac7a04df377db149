//! Artery trackers: pure state machines fed one tactile frame at a time.
//!
//! A tracker sees every tactile frame together with where the robot *believes* the sensor is
//! (encoders plus the fixed-pivot model) and whether the last motion has settled. It answers
//! with a motion command and at most one event per frame. The surgeon's workflow maps onto
//! its methods: [`Tracker::mark`] twice at manual placements to seed, [`Tracker::start`] to
//! follow the artery on its own, [`Tracker::stop`] to end. The simulator's lockstep runner
//! and the daemon drive any tracker through this trait, chosen by name with [`build`].

use serde::{Deserialize, Serialize};

use crate::frames::SurfacePoint;
use crate::types::TactileFrame;

/// What a tracker is given with each tactile frame.
#[derive(Debug, Clone, Copy)]
pub struct TrackerInput<'a> {
    pub frame: &'a TactileFrame,
    /// Where the robot believes the centre of the element line is, tissue frame.
    pub sensor: SurfacePoint,
    /// The last commanded motion has finished: the sensor is within the arrival tolerance
    /// of its target and no longer moving (true when no motion was commanded). Contract:
    /// a `MoveTo` returned for frame k is applied before `settled` is judged for frame k+1,
    /// so from then on `settled` refers to that move.
    pub settled: bool,
    /// Where the arm's torques say the sensor is, the rod's deflection under its load
    /// included (`kinematics::rod_load`), tissue frame; `None` where the rod is not
    /// described. An independent second reading of `sensor`'s place, not a replacement: a
    /// tracker may use it to refuse to report a point whose place the two disagree on.
    pub loaded_sensor: Option<SurfacePoint>,
}

/// Where the tracker wants the sensor to go. A tracker repeats the same `MoveTo` on every
/// frame while it wants that move; an unchanged target continues the move in progress, a
/// changed one replaces it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotionCommand {
    /// Stay (or come to rest) where the sensor is.
    Hold,
    /// Move the centre of the element line to `target` in a straight line at up to
    /// `speed_m_s`, keeping contact with the tissue.
    MoveTo {
        target: SurfacePoint,
        speed_m_s: f64,
    },
}

/// A point the tracker reports as lying on the artery.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LocatedPoint {
    /// Time of the localization, s.
    pub t_s: f64,
    /// The artery point, tissue frame.
    pub point: SurfacePoint,
    /// Where the robot believed the sensor centre was when it localized.
    pub sensor: SurfacePoint,
    /// Position on the array, in (possibly fractional) element indices from element 0.
    pub element: f64,
    /// Pulse amplitude at the located element, N (peak minus off-peak).
    pub amplitude_n: f64,
    /// True for the surgeon's manual placements.
    pub seed: bool,
    /// The point's uncertainty across the artery (one SD, m): the fit's own, the tissue's
    /// unexplained motion and the sensor's uncertain lag behind the belief. `None` from a
    /// tracker that does not estimate it (`seed2002`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sd_m: Option<f64>,
}

/// A point of the course the tracker expects ahead of its last fix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PredictedPoint {
    pub point: SurfacePoint,
    /// Lateral SD of the prediction, m (`None`: the tracker has no model of it).
    pub sd_m: Option<f64>,
}

/// Why tracking ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndReason {
    /// The requested length of artery was followed.
    LengthReached,
    /// The pulse could not be found again: the step fell below its minimum.
    Lost,
    /// The next target lies outside the reachable or allowed workspace.
    WorkspaceEdge,
    /// Stopped on request.
    Stopped,
}

impl EndReason {
    pub fn as_str(&self) -> &'static str {
        match self {
            EndReason::LengthReached => "length_reached",
            EndReason::Lost => "lost",
            EndReason::WorkspaceEdge => "workspace_edge",
            EndReason::Stopped => "stopped",
        }
    }

    /// A normal end of a trial (as opposed to losing the artery or hitting a limit).
    pub fn is_completed(&self) -> bool {
        matches!(self, EndReason::LengthReached)
    }
}

/// Something a tracker reports, at most one per frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrackerEvent {
    /// The artery was found at a point (a seed mark or a tracking step).
    Located(LocatedPoint),
    /// An acquisition here found no pulse.
    Missed { t_s: f64, at: SurfacePoint },
    /// Going back toward the last place the pulse was found.
    Backtracking { t_s: f64, toward: SurfacePoint },
    /// The pulse period estimate changed.
    Pulse { t_s: f64, period_s: f64 },
    /// Tracking ended.
    Finished { t_s: f64, reason: EndReason },
    /// Listening at rest for a pulse too weak to see in one window, once per few seconds.
    Listening(ListenProgress),
}

/// A listen's progress: the evidence so far as an SNR, the SNR a decision needs, the beats
/// weighed, and the beats still to go if the evidence keeps growing as it has (`None`
/// while there is none).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ListenProgress {
    pub t_s: f64,
    pub snr: f64,
    pub snr_needed: f64,
    pub beats: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beats_to_go: Option<f64>,
}

impl ListenProgress {
    /// For people: "listening for a weak pulse: SNR so far 4.2 of 8.0, about 30 beats to
    /// go".
    pub fn describe(&self) -> String {
        let to_go = match self.beats_to_go {
            // Extrapolated from almost no evidence the count means nothing.
            Some(b) if b.is_finite() && b <= 1000.0 => format!("about {b:.0} beats to go"),
            _ => "no sign of a pulse yet".to_string(),
        };
        format!(
            "listening for a weak pulse: SNR so far {:.1} of {:.1}, {to_go}",
            self.snr, self.snr_needed
        )
    }
}

/// A tracker's answer to one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerOutput {
    pub motion: MotionCommand,
    pub event: Option<TrackerEvent>,
}

impl TrackerOutput {
    pub const HOLD: Self = Self {
        motion: MotionCommand::Hold,
        event: None,
    };
}

/// Where a tracker is in the surgeon's workflow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackerPhase {
    /// Waiting for manual placements; holds the number of seed points so far.
    Seeding { seeds: usize },
    /// Acquiring at a manual placement.
    Marking,
    /// Following the artery on its own.
    Tracking,
    /// Done; see the reason.
    Finished(EndReason),
}

/// How far to track.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct TrackLimit {
    /// Stop after following this much artery (path length along the located points from
    /// the first seed), m; `None` tracks until the artery is lost or a limit is met.
    pub length_m: Option<f64>,
}

/// A request the tracker refuses in its current phase.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrackerError {
    #[error("cannot {verb} while {phase}")]
    WrongPhase {
        verb: &'static str,
        phase: &'static str,
    },
    #[error("tracking needs two manual placements where the pulse was found; have {have}")]
    NotSeeded { have: usize },
    #[error("invalid track limit: {0}")]
    BadLimit(String),
    #[error(
        "the seed points give no direction to follow: the last two are {distance_m} m apart, need at least {min_m} m"
    )]
    SeedsTooClose { distance_m: f64, min_m: f64 },
}

impl TrackerPhase {
    pub fn as_str(&self) -> &'static str {
        match self {
            TrackerPhase::Seeding { .. } => "seeding",
            TrackerPhase::Marking => "marking",
            TrackerPhase::Tracking => "tracking",
            TrackerPhase::Finished(_) => "finished",
        }
    }
}

/// The interface every tracker implements.
pub trait Tracker: Send {
    /// The name the command line and config use to select this tracker.
    fn name(&self) -> &'static str;

    fn phase(&self) -> TrackerPhase;

    /// Acquire at the current, stationary, manual placement and localize the artery there.
    /// A `Located` (seed) or `Missed` event follows once the acquisition is complete.
    fn mark(&mut self) -> Result<(), TrackerError>;

    /// Begin following the artery from the seed points.
    fn start(&mut self, limit: TrackLimit) -> Result<(), TrackerError>;

    /// End tracking now (the next step reports `Finished { reason: Stopped }`).
    fn stop(&mut self);

    /// The last commanded target cannot be reached (outside the workspace, too close to the
    /// pivot, out of the depth range): tracking ends with `WorkspaceEdge`.
    fn target_unreachable(&mut self);

    /// Consume one tactile frame.
    fn step(&mut self, input: &TrackerInput<'_>) -> TrackerOutput;

    /// Where the robot believed the sensor was before the tracker was fed its first frame
    /// (the surgeon's approach to the first placement, oldest first). A tracker that models
    /// how the sensor trails the robot's motion learns the approach's direction from it;
    /// the rest ignore it.
    fn approach(&mut self, believed: crate::frames::SurfacePoint) {
        let _ = believed;
    }

    /// The course the tracker expects ahead, from its last fix on, into `out` (cleared
    /// first; empty when it has no model, e.g. before tracking). For display: nothing in the
    /// control path reads it, so it may allocate.
    fn path_ahead(&self, out: &mut Vec<PredictedPoint>) {
        out.clear();
    }
}

pub mod approach;
pub mod beatslide;
pub mod event_queue;
pub mod line_fit;
pub mod seed2002;

use crate::sensor::ArrayGeometry;

/// The names [`build`] knows, as the command line and config spell them.
pub const TRACKER_NAMES: &[&str] = &[seed2002::Seed2002::NAME, beatslide::BeatSlide::NAME];

/// A tracker name that [`build`] does not know.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown tracker `{name}`; known trackers: {}", TRACKER_NAMES.join(", "))]
pub struct UnknownTracker {
    pub name: String,
}

/// Why [`build`] could not make a tracker.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Unknown(#[from] UnknownTracker),
    #[error(transparent)]
    Seed2002(#[from] seed2002::InvalidParams),
    #[error(transparent)]
    BeatSlide(#[from] beatslide::InvalidParams),
}

/// Make the tracker called `name` with its settings from `params`. Allocates every buffer
/// the tracker will use; nothing allocates per frame afterwards.
pub fn build(
    name: &str,
    params: &TrackerParams,
    sensor: &ArrayGeometry,
) -> Result<Box<dyn Tracker>, BuildError> {
    match name {
        seed2002::Seed2002::NAME => {
            Ok(Box::new(seed2002::Seed2002::new(params.seed2002, *sensor)?))
        }
        beatslide::BeatSlide::NAME => Ok(Box::new(beatslide::BeatSlide::new(
            params.beatslide,
            *sensor,
        )?)),
        _ => Err(UnknownTracker {
            name: name.to_string(),
        }
        .into()),
    }
}

/// Settings of every tracker, each under its name.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackerParams {
    pub seed2002: seed2002::Seed2002Params,
    pub beatslide: beatslide::BeatSlideParams,
}

impl TrackerParams {
    /// Set the named tracker's speed setting (the speed of its moves, m/s): `seed2002`'s
    /// `move_speed_m_s`, `beatslide`'s `max_speed_m_s`. For speed-against-error benchmarks.
    pub fn set_speed(&mut self, name: &str, speed_m_s: f64) -> Result<(), UnknownTracker> {
        match name {
            seed2002::Seed2002::NAME => self.seed2002.move_speed_m_s = speed_m_s,
            beatslide::BeatSlide::NAME => self.beatslide.max_speed_m_s = speed_m_s,
            _ => {
                return Err(UnknownTracker {
                    name: name.to_string(),
                });
            }
        }
        Ok(())
    }

    /// The named tracker's speed setting, m/s.
    pub fn speed(&self, name: &str) -> Option<f64> {
        match name {
            seed2002::Seed2002::NAME => Some(self.seed2002.move_speed_m_s),
            beatslide::BeatSlide::NAME => Some(self.beatslide.max_speed_m_s),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_by_name_and_lists_the_names_it_knows() {
        let sensor = ArrayGeometry::default();
        for name in TRACKER_NAMES {
            let t = build(name, &TrackerParams::default(), &sensor).expect("known tracker");
            assert_eq!(t.name(), *name);
            assert_eq!(t.phase(), TrackerPhase::Seeding { seeds: 0 });
        }
        let err = build("seed2003", &TrackerParams::default(), &sensor)
            .err()
            .expect("unknown");
        assert!(matches!(err, BuildError::Unknown(_)));
        let text = err.to_string();
        assert!(
            text.contains("seed2003") && text.contains("seed2002"),
            "{text}"
        );
    }

    #[test]
    fn refuses_parameters_it_cannot_run_with() {
        let sensor = ArrayGeometry::default();
        let mut params = TrackerParams::default();
        params.seed2002.fir_order = 63;
        let err = build("seed2002", &params, &sensor)
            .err()
            .expect("odd order");
        assert!(err.to_string().contains("order"), "{err}");
        let fast = ArrayGeometry {
            sample_rate_hz: 3.0,
            ..sensor
        };
        let err = build("seed2002", &TrackerParams::default(), &fast)
            .err()
            .expect("band above Nyquist");
        assert!(matches!(err, BuildError::Seed2002(_)), "{err}");
    }
}
