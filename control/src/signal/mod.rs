//! The seed's signal processing: band-pass, pulse detection and timing, localization.
//!
//! [`analysis::PulseAnalyzer`] runs the whole chain on one [`window::AcquisitionWindow`];
//! the pieces are public so that they can be tested and measured on their own. Buffers are
//! allocated at construction; analysing a window does not allocate.
//! docs/signal-processing.md describes the algorithm, the choices made and the measurement
//! behind the shipped filter order.
//!
//! The `beatslide` tracker's estimators (docs/tracker-beatslide.md) live beside them:
//! [`harmonic`] (lock-in by least squares on the pulse's harmonics), [`pulse_search`] (a
//! pulse of unknown rate across all elements), [`kernel_fit`] (sub-element localization),
//! [`beat_clock`] (following the heart's phase and rate) and [`noise_level`] (σ from the
//! data).
//!
//! [`detection_bound`] is the reference they are judged against: the beats an ideal
//! detector needs to feel a pulse, and the position bound after them (issue 18).

pub mod analysis;
pub mod bandpass;
pub mod beat_clock;
pub mod beat_interval;
pub mod detect;
pub mod detection_bound;
pub mod harmonic;
pub mod kernel_fit;
pub mod localize;
pub mod noise_level;
pub mod period;
pub mod placed_pulse;
pub mod pulse_search;
pub mod weak_pulse;
pub mod window;

pub use analysis::{AnalysisSettings, NoPulseFound, PulseAnalyzer, PulseFinding};
pub use bandpass::{BandPass, BandPassSpec, FilterDesignError};
pub use detect::{DetectorSettings, NoPulse, PulseTiming, detect_pulse};
pub use localize::{Localization, LocalizerSettings, NotLocated, localize};
pub use period::RunningPeriod;
pub use window::{AcquisitionWindow, Channels, FrameProblem};
