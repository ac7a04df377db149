//! The seed's tracker as a state machine fed one tactile frame at a time.
//!
//! Seeding: each [`Tracker::mark`] acquires at the surgeon's placement (4 s before any
//! pulse period is known, 3 s after) and reports `Located` (seed) or `Missed`. Tracking,
//! after [`Tracker::start`]: fit a line to the last (up to) four located points, move the
//! sensor `step` beyond the last located point along it, wait until the motion layer says
//! the sensor has settled, and acquire up to seven times. A success records the point and
//! grows the step by 5 %; a failure halves the step and re-targets from the last located
//! point (backtracking). Tracking ends when the step falls below its minimum (lost), the
//! located path reaches the requested length, the target is unreachable, or on stop.
//! docs/seed2002.md describes every rule and the reading of the paper behind it.

use super::params::Seed2002Params;
use crate::frames::SurfacePoint;
use crate::sensor::ArrayGeometry;
use crate::signal::{
    AcquisitionWindow, AnalysisSettings, BandPassSpec, DetectorSettings, LocalizerSettings,
    NoPulseFound, PulseAnalyzer, PulseFinding, RunningPeriod,
};
use crate::tracker::event_queue::EventQueue;
use crate::tracker::line_fit::PathLine;
use crate::tracker::{
    EndReason, LocatedPoint, MotionCommand, PredictedPoint, TrackLimit, Tracker, TrackerError,
    TrackerEvent, TrackerInput, TrackerOutput, TrackerPhase,
};

/// The most events one acquisition can queue (a new period, a located point, an end).
const EVENTS_PER_ACQUISITION: usize = 3;

/// Longest acquisition window accepted, samples (bounds the buffers allocated).
const MAX_WINDOW_SAMPLES: usize = 100_000;

/// Parameters the tracker cannot run with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("seed2002: {0}")]
pub struct InvalidParams(pub String);

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// Waiting for the surgeon (manual placements).
    Seeding,
    /// Acquiring at a manual placement.
    Marking,
    /// Moving to `target`; `frames` counts the frames on which the move was commanded.
    Moving {
        target: SurfacePoint,
        frames: u64,
    },
    /// Stationary at `target`, on acquisition number `attempt` (from 1).
    Acquiring {
        target: SurfacePoint,
        attempt: usize,
    },
    Finished(EndReason),
}

/// `seed2002`: the tracker of Beasley & Howe (2002).
#[derive(Debug, Clone)]
pub struct Seed2002 {
    params: Seed2002Params,
    geometry: ArrayGeometry,
    analyzer: PulseAnalyzer,
    window: AcquisitionWindow,
    first_window_samples: usize,
    window_samples: usize,
    period: RunningPeriod,
    /// The last located artery points, oldest first, at most `regression_points`.
    recent: Vec<SurfacePoint>,
    seeds: usize,
    last_found: Option<SurfacePoint>,
    path_length_m: f64,
    line: Option<PathLine>,
    step_m: f64,
    limit: TrackLimit,
    state: State,
    pending_end: Option<EndReason>,
    events: EventQueue,
    sensor_sum: [f64; 2],
    sensor_count: usize,
    rejected_frames: u64,
    last_miss: Option<NoPulseFound>,
}

impl Seed2002 {
    pub const NAME: &'static str = "seed2002";

    /// Build the tracker; allocates every buffer it will use.
    pub fn new(params: Seed2002Params, geometry: ArrayGeometry) -> Result<Self, InvalidParams> {
        geometry.check().map_err(InvalidParams)?;
        let fs = geometry.sample_rate_hz;
        let samples = |name: &str, seconds: f64| {
            let n = (seconds * fs).round();
            if n.is_finite() && n >= 3.0 && n <= MAX_WINDOW_SAMPLES as f64 {
                Ok(n as usize)
            } else {
                Err(InvalidParams(format!(
                    "{name} = {seconds} s gives {n} samples at {fs} Hz; need 3 to {MAX_WINDOW_SAMPLES}"
                )))
            }
        };
        let first_window_samples = samples("first_window_s", params.first_window_s)?;
        let window_samples = samples("window_s", params.window_s)?;
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(InvalidParams(format!("{name} must be positive, got {v}")))
            }
        };
        positive("min_step_m", params.min_step_m)?;
        positive("move_speed_m_s", params.move_speed_m_s)?;
        positive("sigma_factor", params.sigma_factor)?;
        if !(params.step_growth.is_finite() && params.step_growth >= 1.0) {
            return Err(InvalidParams(format!(
                "step_growth must be at least 1, got {}",
                params.step_growth
            )));
        }
        if !(params.backtrack_factor > 0.0 && params.backtrack_factor < 1.0) {
            return Err(InvalidParams(format!(
                "backtrack_factor must lie between 0 and 1, got {}",
                params.backtrack_factor
            )));
        }
        if !(2..=1000).contains(&params.regression_points) || params.max_acquisitions == 0 {
            return Err(InvalidParams(format!(
                "regression_points must be 2 to 1000 and max_acquisitions at least 1, got {} and {}",
                params.regression_points, params.max_acquisitions
            )));
        }
        let settings = AnalysisSettings {
            band: BandPassSpec {
                order: params.fir_order,
                low_hz: params.band_low_hz,
                high_hz: params.band_high_hz,
                sample_rate_hz: fs,
            },
            detector: DetectorSettings {
                threshold_fraction: params.threshold_fraction,
                min_period_s: params.min_period_s,
                max_period_s: params.max_period_s,
            },
            localizer: LocalizerSettings {
                samples_per_mean: params.samples_per_mean,
                sigma_factor: params.sigma_factor,
                noise_sd_n: geometry.noise_sd_n,
            },
            localize_filtered: params.localize_filtered,
        };
        let capacity = first_window_samples.max(window_samples);
        let analyzer =
            PulseAnalyzer::new(settings, capacity).map_err(|e| InvalidParams(e.to_string()))?;
        Ok(Self {
            params,
            geometry,
            analyzer,
            window: AcquisitionWindow::new(capacity, fs),
            first_window_samples,
            window_samples,
            period: RunningPeriod::new(),
            recent: Vec::with_capacity(params.regression_points),
            seeds: 0,
            last_found: None,
            path_length_m: 0.0,
            line: None,
            step_m: 0.0,
            limit: TrackLimit::default(),
            state: State::Seeding,
            pending_end: None,
            events: EventQueue::default(),
            sensor_sum: [0.0; 2],
            sensor_count: 0,
            rejected_frames: 0,
            last_miss: None,
        })
    }

    pub fn params(&self) -> &Seed2002Params {
        &self.params
    }

    /// The running pulse period estimate, s.
    pub fn period_estimate_s(&self) -> Option<f64> {
        self.period.estimate_s()
    }

    /// The current step, m (0 before tracking starts).
    pub fn step_m(&self) -> f64 {
        self.step_m
    }

    /// Path length along the located points from the first seed, m.
    pub fn path_length_m(&self) -> f64 {
        self.path_length_m
    }

    /// The line the last target was extrapolated along.
    pub fn line(&self) -> Option<PathLine> {
        self.line
    }

    /// Frames refused so far (non-finite, dropped or out of order); each restarts the
    /// acquisition in progress.
    pub fn rejected_frames(&self) -> u64 {
        self.rejected_frames
    }

    /// Why the last unsuccessful acquisition found no artery.
    pub fn last_miss(&self) -> Option<NoPulseFound> {
        self.last_miss
    }

    /// The signal chain (for its filter and the last filtered window).
    pub fn analyzer(&self) -> &PulseAnalyzer {
        &self.analyzer
    }

    fn begin_acquisition(&mut self) {
        let samples = if self.period.estimate_s().is_some() {
            self.window_samples
        } else {
            self.first_window_samples
        };
        self.window.begin(samples);
        self.sensor_sum = [0.0; 2];
        self.sensor_count = 0;
    }

    /// Add a frame to the acquisition; sampling only happens while the sensor is at rest.
    fn acquire(&mut self, input: &TrackerInput<'_>) {
        if !input.settled || !input.sensor.is_finite() {
            self.window.clear();
            self.sensor_sum = [0.0; 2];
            self.sensor_count = 0;
            return;
        }
        if self.window.is_full() {
            return;
        }
        if self.window.push(input.frame).is_err() {
            self.rejected_frames += 1;
            self.sensor_sum = [0.0; 2];
            self.sensor_count = 0;
            if self.window.is_empty() {
                return;
            }
        }
        self.sensor_sum[0] += input.sensor.x_m;
        self.sensor_sum[1] += input.sensor.z_m;
        self.sensor_count += 1;
    }

    /// The mean believed sensor centre over the acquisition.
    fn mean_sensor(&self) -> SurfacePoint {
        let n = self.sensor_count.max(1) as f64;
        SurfacePoint::new(self.sensor_sum[0] / n, self.sensor_sum[1] / n)
    }

    fn ready_to_analyse(&self) -> bool {
        self.window.is_full() && self.events.has_room_for(EVENTS_PER_ACQUISITION)
    }

    fn emit(&mut self, event: TrackerEvent) {
        // Capacity is reserved before each acquisition is analysed, and at most one end
        // event follows; a full queue would mean that accounting is broken.
        let pushed = self.events.push(event);
        debug_assert!(pushed.is_ok(), "tracker event queue overflow");
    }

    /// Analyse the full window; on success commit the period and record the point.
    fn analyse(&mut self, t_s: f64, seed: bool) -> Option<LocatedPoint> {
        let sensor = self.mean_sensor();
        match self.analyzer.analyse(&self.window, &self.period) {
            Ok(finding) => {
                self.commit_period(&finding, t_s);
                let located = self.located_point(&finding, sensor, t_s, seed);
                self.record(located.point);
                self.emit(TrackerEvent::Located(located));
                Some(located)
            }
            Err(miss) => {
                self.last_miss = Some(miss);
                None
            }
        }
    }

    fn commit_period(&mut self, finding: &PulseFinding, t_s: f64) {
        let before = self.period.estimate_s();
        let after = self.period.update(finding.timing.period_s);
        if let Some(period_s) = after
            && after != before
        {
            self.emit(TrackerEvent::Pulse { t_s, period_s });
        }
    }

    fn located_point(
        &self,
        finding: &PulseFinding,
        sensor: SurfacePoint,
        t_s: f64,
        seed: bool,
    ) -> LocatedPoint {
        let element = finding.localization.element;
        LocatedPoint {
            t_s,
            point: SurfacePoint::new(sensor.x_m, sensor.z_m + self.geometry.offset_z_m(element)),
            sensor,
            element,
            amplitude_n: finding.localization.amplitude_n,
            seed,
            sd_m: None,
        }
    }

    fn record(&mut self, point: SurfacePoint) {
        if let Some(previous) = self.last_found {
            self.path_length_m += previous.distance_to(&point);
        }
        self.last_found = Some(point);
        if self.recent.len() == self.params.regression_points {
            self.recent.remove(0);
        }
        self.recent.push(point);
    }

    fn length_reached(&self) -> bool {
        self.limit
            .length_m
            .is_some_and(|length_m| self.path_length_m >= length_m)
    }

    fn finish(&mut self, reason: EndReason, t_s: f64) {
        self.state = State::Finished(reason);
        self.emit(TrackerEvent::Finished { t_s, reason });
    }

    /// The point `step` beyond the last located point along the line through the recent
    /// points (the previous line if they no longer define one).
    fn next_target(&mut self) -> Option<SurfacePoint> {
        if let Some(line) = PathLine::fit(&self.recent) {
            self.line = Some(line);
        }
        let line = self.line?;
        let from = self.last_found?;
        let target = line.beyond(&from, self.step_m);
        target.is_finite().then_some(target)
    }

    fn move_to(&mut self, target: SurfacePoint) {
        self.state = State::Moving { target, frames: 0 };
    }

    fn complete_mark(&mut self, t_s: f64) {
        let at = self.mean_sensor();
        if self.analyse(t_s, true).is_some() {
            self.seeds += 1;
        } else {
            self.emit(TrackerEvent::Missed { t_s, at });
        }
        self.state = State::Seeding;
    }

    fn complete_attempt(&mut self, target: SurfacePoint, attempt: usize, t_s: f64) {
        let at = self.mean_sensor();
        if self.analyse(t_s, false).is_some() {
            if self.length_reached() {
                self.finish(EndReason::LengthReached, t_s);
                return;
            }
            self.step_m *= self.params.step_growth;
            if let Some(max_step_m) = self.params.max_step_m {
                self.step_m = self.step_m.min(max_step_m);
            }
            match self.next_target() {
                Some(next) => self.move_to(next),
                None => self.finish(EndReason::Lost, t_s),
            }
            return;
        }
        if attempt < self.params.max_acquisitions {
            self.state = State::Acquiring {
                target,
                attempt: attempt + 1,
            };
            self.begin_acquisition();
            return;
        }
        self.emit(TrackerEvent::Missed { t_s, at });
        self.step_m *= self.params.backtrack_factor;
        if self.step_m < self.params.min_step_m {
            self.finish(EndReason::Lost, t_s);
            return;
        }
        match self.next_target() {
            Some(toward) => {
                self.emit(TrackerEvent::Backtracking { t_s, toward });
                self.move_to(toward);
            }
            None => self.finish(EndReason::Lost, t_s),
        }
    }
}

impl Tracker for Seed2002 {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    /// The 2002 method's whole model of the path: the straight line through the recent
    /// points, one step on from the last point found. It has no estimate of its error.
    fn path_ahead(&self, out: &mut Vec<PredictedPoint>) {
        out.clear();
        if self.phase() != TrackerPhase::Tracking {
            return;
        }
        let (Some(line), Some(from)) = (self.line, self.last_found) else {
            return;
        };
        let ahead = line.beyond(&from, self.step_m);
        if from.is_finite() && ahead.is_finite() {
            out.extend([from, ahead].map(|point| PredictedPoint { point, sd_m: None }));
        }
    }

    fn phase(&self) -> TrackerPhase {
        if let Some(reason) = self.pending_end {
            return TrackerPhase::Finished(reason);
        }
        match self.state {
            State::Seeding => TrackerPhase::Seeding { seeds: self.seeds },
            State::Marking => TrackerPhase::Marking,
            State::Moving { .. } | State::Acquiring { .. } => TrackerPhase::Tracking,
            State::Finished(reason) => TrackerPhase::Finished(reason),
        }
    }

    fn mark(&mut self) -> Result<(), TrackerError> {
        match self.phase() {
            TrackerPhase::Seeding { .. } => {
                self.state = State::Marking;
                self.begin_acquisition();
                Ok(())
            }
            phase => Err(TrackerError::WrongPhase {
                verb: "mark",
                phase: phase.as_str(),
            }),
        }
    }

    fn start(&mut self, limit: TrackLimit) -> Result<(), TrackerError> {
        let phase = self.phase();
        if !matches!(phase, TrackerPhase::Seeding { .. }) {
            return Err(TrackerError::WrongPhase {
                verb: "start",
                phase: phase.as_str(),
            });
        }
        if self.seeds < 2 {
            return Err(TrackerError::NotSeeded { have: self.seeds });
        }
        if let Some(length_m) = limit.length_m
            && !(length_m.is_finite() && length_m > 0.0)
        {
            return Err(TrackerError::BadLimit(format!(
                "length_m must be positive, got {length_m}"
            )));
        }
        let n = self.recent.len();
        let spacing_m = self.recent[n - 2].distance_to(&self.recent[n - 1]);
        let step_m = self.params.initial_step_m.unwrap_or(spacing_m);
        let line = PathLine::fit(&self.recent);
        if line.is_none() || step_m < self.params.min_step_m {
            return Err(TrackerError::SeedsTooClose {
                distance_m: spacing_m,
                min_m: self.params.min_step_m,
            });
        }
        self.line = line;
        self.limit = limit;
        self.step_m = match self.params.max_step_m {
            Some(max_step_m) => step_m.min(max_step_m),
            None => step_m,
        };
        if self.length_reached() {
            self.pending_end = Some(EndReason::LengthReached);
            return Ok(());
        }
        match self.next_target() {
            Some(target) => {
                self.move_to(target);
                Ok(())
            }
            None => Err(TrackerError::SeedsTooClose {
                distance_m: spacing_m,
                min_m: self.params.min_step_m,
            }),
        }
    }

    fn stop(&mut self) {
        if !matches!(self.phase(), TrackerPhase::Finished(_)) {
            self.pending_end = Some(EndReason::Stopped);
        }
    }

    fn target_unreachable(&mut self) {
        if matches!(self.phase(), TrackerPhase::Tracking) {
            self.pending_end = Some(EndReason::WorkspaceEdge);
        }
    }

    fn step(&mut self, input: &TrackerInput<'_>) -> TrackerOutput {
        let t_s = input.frame.t_s;
        if let Some(reason) = self.pending_end.take() {
            self.finish(reason, t_s);
        }
        let motion = match self.state {
            State::Seeding | State::Finished(_) => MotionCommand::Hold,
            State::Marking => {
                self.acquire(input);
                if self.ready_to_analyse() {
                    self.complete_mark(t_s);
                }
                MotionCommand::Hold
            }
            State::Moving { target, frames } => {
                // `settled` refers to the move once it has been commanded on an earlier
                // frame (the contract on `TrackerInput::settled`).
                if frames > 0 && input.settled {
                    self.state = State::Acquiring { target, attempt: 1 };
                    self.begin_acquisition();
                    self.acquire(input);
                }
                self.motion()
            }
            State::Acquiring { target, attempt } => {
                self.acquire(input);
                if self.ready_to_analyse() {
                    self.complete_attempt(target, attempt, t_s);
                }
                self.motion()
            }
        };
        if let State::Moving { target, frames } = self.state {
            self.state = State::Moving {
                target,
                frames: frames.saturating_add(1),
            };
        }
        TrackerOutput {
            motion,
            event: self.events.pop(),
        }
    }
}

impl Seed2002 {
    fn motion(&self) -> MotionCommand {
        match self.state {
            State::Moving { target, .. } => MotionCommand::MoveTo {
                target,
                speed_m_s: self.params.move_speed_m_s,
            },
            _ => MotionCommand::Hold,
        }
    }
}
