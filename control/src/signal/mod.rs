//! The seed's signal processing: band-pass, pulse detection and timing, localization.
//!
//! [`analysis::PulseAnalyzer`] runs the whole chain on one [`window::AcquisitionWindow`];
//! the pieces are public so that they can be tested and measured on their own. Buffers are
//! allocated at construction; analysing a window does not allocate.
//! docs/signal-processing.md describes the algorithm, the choices made and the measurement
//! behind the shipped filter order.

pub mod analysis;
pub mod bandpass;
pub mod detect;
pub mod localize;
pub mod period;
pub mod window;

pub use analysis::{AnalysisSettings, NoPulseFound, PulseAnalyzer, PulseFinding};
pub use bandpass::{BandPass, BandPassSpec, FilterDesignError};
pub use detect::{DetectorSettings, NoPulse, PulseTiming, detect_pulse};
pub use localize::{Localization, LocalizerSettings, NotLocated, localize};
pub use period::RunningPeriod;
pub use window::{AcquisitionWindow, Channels, FrameProblem};
