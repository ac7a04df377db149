//! Finding the artery without being shown (issue 17): the surgeon names a region of the
//! tissue surface, and the searcher explores it with looks at rest, keeps a posterior over
//! where the artery runs ([`line_map`]), chooses each next look for the most information
//! per second ([`plan`]), and stops when the artery's place and heading are known (two
//! felt points to seed a tracker) or when no artery is the likelier answer.
//!
//! A look is the mark's analysis: a window at rest, the pulse searched over the period
//! (the pulsatility test: a lump or a drift does not pulse) and placed on the array by the
//! kernel fit ([`crate::signal::placed_pulse`]). Like a tracker the searcher is a pure state
//! machine fed one tactile frame at a time with where the robot believes the sensor is; the
//! lockstep runner and the daemon drive it the same way. It only ever asks for looks inside
//! the region, and moves between them in straight lines, so a sensor that starts inside
//! never leaves it.
//!
//! docs/search.md describes the method, its limits and its benchmark.

pub mod line_map;
pub mod params;
pub mod plan;
pub mod region;
mod searcher;

pub use line_map::{LineMap, LookReading, MapSettings, MapSummary};
pub use params::{ParamsError, SearchParams};
pub use plan::SearchMethod;
pub use region::{Region, RegionError};
pub use searcher::{BuildError, Searcher};

use serde::Serialize;

use crate::frames::SurfacePoint;
use crate::tracker::{LocatedPoint, MotionCommand};

/// What one look found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LookReport {
    /// When the look's window ended, s.
    pub t_s: f64,
    /// Where the robot believed the sensor centre was (mean over the window).
    pub at: SurfacePoint,
    /// The window's length, s.
    pub duration_s: f64,
    /// The felt artery point, when a pulse was found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub felt: Option<LocatedPoint>,
    /// The pulse period the look found, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f64>,
    /// The posterior after it.
    pub p_present: f64,
    pub heading_rad: f64,
    pub heading_sd_rad: f64,
    /// Looks so far, this one included.
    pub looks: usize,
}

/// Why a search ended without an artery.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NotFoundReason {
    /// No artery is the likelier answer, to the configured confidence.
    NothingPulses,
    /// The time allowed ran out.
    TimeLimit,
    /// No look left would tell more (a raster done, or every place tried).
    NothingLeftToLearn,
}

impl NotFoundReason {
    pub fn as_str(&self) -> &'static str {
        match self {
            NotFoundReason::NothingPulses => "nothing_pulses",
            NotFoundReason::TimeLimit => "time_limit",
            NotFoundReason::NothingLeftToLearn => "nothing_left_to_learn",
        }
    }
}

/// How a search ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum SearchOutcome {
    /// The artery: two felt points (as seeds, ordered along `+x`) and the line's heading.
    Found {
        t_s: f64,
        seeds: [LocatedPoint; 2],
        heading_rad: f64,
        heading_sd_rad: f64,
        p_present: f64,
        looks: usize,
    },
    /// No artery, with how sure and the weakest pulse the looks would have felt: a pulse
    /// weaker than `weakest_felt_n` (on its strongest element) may have been missed.
    NotFound {
        t_s: f64,
        reason: NotFoundReason,
        p_present: f64,
        weakest_felt_n: f64,
        looks: usize,
    },
    /// Stopped on request.
    Stopped { t_s: f64, looks: usize },
}

impl SearchOutcome {
    pub fn is_found(&self) -> bool {
        matches!(self, SearchOutcome::Found { .. })
    }
}

/// Something the searcher reports, at most one per frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SearchEvent {
    Look(LookReport),
    Finished(SearchOutcome),
}

/// The searcher's answer to one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchOutput {
    pub motion: MotionCommand,
    pub event: Option<SearchEvent>,
}

#[cfg(test)]
mod tests;
