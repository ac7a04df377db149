//! The live view's own messages (the rest are the recording's, [`crate::recording::messages`]);
//! their JSON Schemas are derived from these types.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use control::types::ELEMENTS;

/// A tactile frame through the band-pass (`/tactile/bandpassed`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BandPassedFrame {
    /// Daemon clock of the raw frame this sample belongs to, s: the filter is linear-phase and
    /// its delay is taken out, so a peak here lines up with the raw peak.
    pub t_s: f64,
    pub seq: u64,
    /// Band-passed force per element, N.
    pub force_n: [f64; ELEMENTS],
    /// How late this sample is published after its raw frame (the filter's half length), s.
    pub delay_s: f64,
}

/// The pulse (`/pulse`), ten times a second.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PulseSample {
    /// Daemon clock of the newest band-passed sample used, s.
    pub t_s: f64,
    /// The trial's tracker's latest pulse period, s (`null` until it reports one).
    pub period_s: Option<f64>,
    /// Peak-to-peak band-passed force per element over the last `window_s`, N.
    pub amplitude_n: [f64; ELEMENTS],
    pub window_s: f64,
    /// The element with the largest swing.
    pub strongest_element: usize,
    /// The beats in the window, daemon clock, s: the strongest element's band-passed peaks
    /// (docs/foxglove.md; on a trace with no pulse, the noise's own).
    #[serde(default)]
    pub beat_times_s: Vec<f64>,
}

/// The 1 kHz loop's timing and the live view's losses (`/loop`), four times a second.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct LoopTiming {
    pub t_s: f64,
    /// Control cycles run.
    pub cycles: u64,
    /// Cycles whose work ended after the next deadline.
    pub overruns: u64,
    /// Samples the loop dropped because the supervisor lagged.
    pub loop_dropped: u64,
    /// Messages dropped on the way to the live view (its queue was full).
    pub live_dropped: u64,
    /// The loop's last timing report (every `realtime.overrun_report_s`): wall-time period
    /// percentiles, µs.
    pub period_p50_us: Option<f64>,
    pub period_p99_us: Option<f64>,
    pub period_max_us: Option<f64>,
}

/// The operating state (`/state`), on every change and four times a second.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct LiveState {
    pub t_s: f64,
    /// `disabled`, `holding`, `moving`, `seeding`, `tracking`, `paused`, `done`, `fault`.
    pub state: String,
    /// The latched fault's reason.
    pub fault: Option<String>,
    /// The open trial.
    pub trial: Option<String>,
    pub seeds: usize,
    pub located: usize,
    pub followed_m: f64,
}
