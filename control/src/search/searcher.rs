//! The search's state machine: move to a look, settle, look, update the map, decide.

use std::collections::VecDeque;

use crate::frames::SurfacePoint;
use crate::sensor::ArrayGeometry;
use crate::signal::detection_bound::chi2_quantile;
use crate::signal::noise_level::NoiseLevel;
use crate::signal::placed_pulse::{PlacedPulse, placed_pulse};
use crate::signal::pulse_search::{PulseSearch, PulseSearchSettings};
use crate::tracker::{LocatedPoint, MotionCommand, TrackerInput};
use crate::types::{ELEMENTS, TactileFrame};

use super::line_map::{LineMap, LookReading, MapSettings};
use super::params::{ParamsError, SearchParams};
use super::plan::{self, PlanScratch, SearchMethod};
use super::region::Region;
use super::{LookReport, NotFoundReason, SearchEvent, SearchOutcome, SearchOutput};

/// Samples per block in the period search (as `beatslide`'s marks).
const SEARCH_DECIMATION: usize = 4;
/// Periods a look must hold once the period is known is `look_periods`; the search is
/// narrowed to this fraction about the known period.
const KNOWN_PERIOD_RANGE: f64 = 0.15;
/// A look's phase is taken as held over this long (as `beatslide`'s `coherent_s`).
const COHERENT_S: f64 = 12.0;
/// A felt point agrees with the best line within this many of its SDs.
const AGREE_SIGMAS: f64 = 3.0;
/// A placed pulse weaker than this fraction of the strongest placed so far is read as a
/// flank: a kernel's far lobe (an artery 10-20 mm off the array) pulses at a tenth of the
/// artery's amplitude, inverted, and the fit places it on the array (measured on the seed's
/// bench: 2.4-3.6 mN against 45 mN over the artery).
const FAINT_FRACTION: f64 = 0.3;
/// Over the outer two elements, the fraction of the strongest placed pulse a pulse needs
/// (measured on the seed's bench: a flank 1.7 mm beyond the array's end was placed over
/// its last element at 22 mN against the artery's 44 mN).
const EDGE_FRACTION: f64 = 0.7;
/// How much better a pulse must fit the kernel than its inverse to be placed: a
/// likelihood ratio of 100, as `beatslide`'s marks require (a weak pulse of unknown sign
/// was placed on the wrong side of the array, 15 mm off, on a fast, weak heart).
const SIGN_MARGIN_CHI2: f64 = 9.21;
/// The kernel fit's false alarm on a still artery (as `beatslide`'s).
const KERNEL_FIT_FALSE_ALARM: f64 = 1e-3;
/// Moves shorter than this teach nothing about the lag and are not aimed past, m.
const LAG_MOVE_MIN_M: f64 = 2e-3;
/// The largest lag believed, m: more is a sensor that did not arrive, not a lag.
const MAX_LAG_M: f64 = 8e-3;
/// A pulse placed more loosely than this is a flank, not a place, m.
const MAX_PLACED_SE_M: f64 = 1e-3;
/// The SNR the weakest felt pulse is reported at (the detection statistic's scale).
const FELT_SNR: f64 = 8.0;

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// Not yet given a frame: choose the first look.
    Start,
    Moving {
        target: SurfacePoint,
    },
    Settling {
        until_s: f64,
    },
    Looking {
        since_s: f64,
        until_s: f64,
    },
    Done,
}

/// One look kept: the map is rebuilt from all of them after each look, so that a pulse
/// taken for the artery's until a far stronger one was felt can be read again as a flank.
#[derive(Debug, Clone, Copy)]
struct Record {
    at: SurfacePoint,
    pulse: Option<Pulse>,
}

#[derive(Debug, Clone, Copy)]
struct Pulse {
    point: LocatedPoint,
    se_m: f64,
    /// The kernel placed it on the array (not at or beyond its edge, not loosely).
    placed: bool,
}

/// Why a searcher cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Params(#[from] ParamsError),
    #[error("sensor: {0}")]
    Sensor(String),
    #[error(transparent)]
    Region(#[from] super::region::RegionError),
}

/// The searcher. Build it with the array's geometry and the region; feed it every frame.
pub struct Searcher {
    params: SearchParams,
    geometry: ArrayGeometry,
    region: Region,
    method: SearchMethod,
    map: LineMap,
    state: State,
    events: VecDeque<SearchEvent>,
    outcome: Option<SearchOutcome>,
    frames: Vec<TactileFrame>,
    believed_sum: (f64, f64, usize),
    pulse_search: PulseSearch,
    noise: NoiseLevel,
    period_s: Option<f64>,
    records: Vec<Record>,
    map_settings: MapSettings,
    loaded_sum: (f64, f64, usize),
    looks: usize,
    shortest_miss_samples: Option<usize>,
    started_s: Option<f64>,
    candidates: Vec<SurfacePoint>,
    raster: Vec<SurfacePoint>,
    raster_next: usize,
    unreachable: Vec<SurfacePoint>,
    scratch: PlanScratch,
    last_target: Option<SurfacePoint>,
    /// Every look asked for: a place is not asked for twice (where the sensor ended up may
    /// differ from where it was asked to go, by the rod's bending).
    asked: Vec<SurfacePoint>,
    /// How far short of its aim the sensor comes to rest, m, and the move under way (from
    /// the last look's place to the next look).
    lag_m: f64,
    moving: Option<(SurfacePoint, SurfacePoint)>,
    /// The strongest placed pulse's kernel SNR over the square root of its look's length.
    snr_per_root_s: Option<f64>,
}

impl std::fmt::Debug for Searcher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Searcher")
            .field("method", &self.method)
            .field("region", &self.region)
            .field("state", &self.state)
            .field("looks", &self.looks)
            .field("outcome", &self.outcome)
            .finish_non_exhaustive()
    }
}

/// Half the span along `z` over which a look feels an artery: the outer elements' centres
/// plus half a pitch.
fn reach_m(geometry: &ArrayGeometry) -> f64 {
    (ELEMENTS as f64 / 2.0) * geometry.pitch_m
}

impl Searcher {
    pub fn new(
        params: SearchParams,
        geometry: ArrayGeometry,
        region: Region,
        method: SearchMethod,
    ) -> Result<Self, BuildError> {
        params.validate()?;
        geometry.check().map_err(BuildError::Sensor)?;
        region.validate()?;
        let reach = reach_m(&geometry);
        let map_settings = MapSettings {
            max_heading_rad: params.max_heading_rad,
            heading_centre_rad: 0.0,
            offset_step_m: params.offset_step_m,
            heading_step_rad: params.heading_step_rad,
            reach_m: reach,
            p_detect: params.p_detect,
            p_false: params.p_false,
            place_floor_m: params.place_floor_m,
            prior_absent: params.prior_absent,
        };
        let map = LineMap::new(&region, map_settings);
        let looks_in = region.inset(params.edge_margin_m);
        let capacity = ((params
            .first_look_s
            .max(params.look_periods * params.max_period_s)
            + 1.0)
            * geometry.sample_rate_hz)
            .ceil() as usize;
        Ok(Self {
            map,
            state: State::Start,
            events: VecDeque::new(),
            outcome: None,
            frames: Vec::with_capacity(capacity),
            believed_sum: (0.0, 0.0, 0),
            pulse_search: PulseSearch::new(capacity),
            noise: NoiseLevel::new(capacity),
            period_s: None,
            records: Vec::new(),
            map_settings,
            loaded_sum: (0.0, 0.0, 0),
            looks: 0,
            shortest_miss_samples: None,
            started_s: None,
            candidates: plan::candidate_looks(&looks_in, params.candidate_step_m),
            raster: plan::raster_looks(&looks_in, reach, params.seed_separation_m),
            raster_next: 0,
            unreachable: Vec::new(),
            scratch: PlanScratch::default(),
            last_target: None,
            asked: Vec::new(),
            lag_m: 0.0,
            moving: None,
            snr_per_root_s: None,
            params,
            geometry,
            region,
            method,
        })
    }

    /// Expect the artery to run at `heading_rad` from `+x` (the surgeon's guess of its
    /// course): the prior cone of `max_heading_rad` is centred there. Only before the
    /// first frame.
    pub fn expect_heading(mut self, heading_rad: f64) -> Result<Self, BuildError> {
        if !(heading_rad.is_finite() && heading_rad.abs() <= super::line_map::MAX_HEADING_RAD) {
            return Err(BuildError::Params(ParamsError {
                field: "heading_rad",
                value: heading_rad,
                why: "must lie within 80 degrees of x (the array follows only an artery that crosses it)",
            }));
        }
        self.map_settings.heading_centre_rad = heading_rad;
        self.map = LineMap::new(&self.region, self.map_settings);
        Ok(self)
    }

    pub fn region(&self) -> &Region {
        &self.region
    }

    pub fn method(&self) -> SearchMethod {
        self.method
    }

    pub fn map(&self) -> &LineMap {
        &self.map
    }

    /// How the search ended, once it has.
    pub fn outcome(&self) -> Option<&SearchOutcome> {
        self.outcome.as_ref()
    }

    /// End now (the next step reports `Stopped`).
    pub fn stop(&mut self) {
        if self.outcome.is_none() {
            let t_s = self.last_time();
            self.finish(SearchOutcome::Stopped {
                t_s,
                looks: self.looks,
            });
        }
    }

    /// The last look asked for cannot be reached: it is not asked for again, and the next
    /// is chosen from where the sensor is.
    pub fn target_unreachable(&mut self) {
        if let Some(t) = self.last_target.take() {
            self.unreachable.push(t);
        }
        if matches!(self.state, State::Moving { .. }) {
            self.state = State::Start;
        }
    }

    fn last_time(&self) -> f64 {
        self.frames
            .last()
            .map_or(self.started_s.unwrap_or(0.0), |f| f.t_s)
    }

    fn finish(&mut self, outcome: SearchOutcome) {
        self.outcome = Some(outcome);
        self.events.push_back(SearchEvent::Finished(outcome));
        self.state = State::Done;
    }

    /// Consume one frame.
    pub fn step(&mut self, input: &TrackerInput<'_>) -> SearchOutput {
        let t = input.frame.t_s;
        let started = *self.started_s.get_or_insert(t);
        if self.outcome.is_none() && t - started > self.params.max_time_s {
            self.not_found(t, NotFoundReason::TimeLimit);
        }
        let motion = match self.state {
            State::Done => MotionCommand::Hold,
            State::Start => self.next_look(t, input.sensor),
            State::Moving { target } => {
                if input.settled {
                    self.state = State::Settling {
                        until_s: t + self.params.settle_s,
                    };
                    MotionCommand::Hold
                } else {
                    MotionCommand::MoveTo {
                        target,
                        speed_m_s: self.params.speed_m_s,
                    }
                }
            }
            State::Settling { until_s } => {
                if t >= until_s {
                    self.frames.clear();
                    self.believed_sum = (0.0, 0.0, 0);
                    self.loaded_sum = (0.0, 0.0, 0);
                    self.state = State::Looking {
                        since_s: t,
                        until_s: t + self.look_s(),
                    };
                }
                MotionCommand::Hold
            }
            State::Looking { since_s, until_s } => {
                if input.frame.is_finite() && self.frames.len() < self.frames.capacity() {
                    self.frames.push(*input.frame);
                }
                for (sum, p) in [
                    (&mut self.believed_sum, Some(input.sensor)),
                    (&mut self.loaded_sum, input.loaded_sensor),
                ] {
                    if let Some(p) = p.filter(|p| p.is_finite()) {
                        sum.0 += p.x_m;
                        sum.1 += p.z_m;
                        sum.2 += 1;
                    }
                }
                if t >= until_s {
                    self.end_look(t, since_s, input.sensor)
                } else {
                    MotionCommand::Hold
                }
            }
        };
        SearchOutput {
            motion,
            event: self.events.pop_front(),
        }
    }

    /// The length of the next look, s.
    fn look_s(&self) -> f64 {
        match self.period_s {
            Some(p) => {
                let shortest = self.params.look_periods * p * (1.0 + KNOWN_PERIOD_RANGE);
                // Long enough that the artery's pulse, as strong as the strongest felt,
                // reaches the look SNR: a weak pulse is felt by waiting, and a look too short
                // to feel it would count as a miss against where it is.
                let needed = self
                    .snr_per_root_s
                    .map_or(0.0, |r| (self.params.look_snr / r).powi(2));
                needed.clamp(shortest, self.params.max_look_s.max(shortest))
            }
            None => self.params.first_look_s,
        }
    }

    fn settings(&self) -> PulseSearchSettings {
        let (lo, hi) = match self.period_s {
            Some(p) => (
                (p * (1.0 - KNOWN_PERIOD_RANGE)).max(self.params.min_period_s),
                (p * (1.0 + KNOWN_PERIOD_RANGE)).min(self.params.max_period_s),
            ),
            None => (self.params.min_period_s, self.params.max_period_s),
        };
        PulseSearchSettings {
            min_period_s: lo,
            max_period_s: hi,
            threshold: self.params.detection_threshold,
            decimation: SEARCH_DECIMATION,
            min_cycles: if self.period_s.is_some() { 2.0 } else { 2.5 },
            coherent_s: COHERENT_S,
            plausible_min_period_s: self.params.min_period_s,
            plausible_max_period_s: self.params.max_period_s,
        }
    }

    /// Where the sensor was over the look: the arm's load's reading where every frame had
    /// one (it includes the rod's deflection, which leaves the encoders' belief millimetres
    /// off after a move), else the belief.
    fn look_place(&self, now: SurfacePoint) -> SurfacePoint {
        let mean = |(x, z, n): (f64, f64, usize)| SurfacePoint::new(x / n as f64, z / n as f64);
        let (b, l) = (self.believed_sum, self.loaded_sum);
        if l.2 > 0 && l.2 == b.2 {
            mean(l)
        } else if b.2 > 0 {
            mean(b)
        } else {
            now
        }
    }

    /// How a kept look reads given the strongest placed pulse so far.
    fn reading(&self, r: &Record, strongest_n: f64) -> LookReading {
        match r.pulse {
            None => LookReading::Nothing,
            Some(p) if p.placed && p.point.amplitude_n >= self.usual_fraction(r) * strongest_n => {
                LookReading::Felt {
                    offset_z_m: p.point.point.z_m - r.at.z_m,
                    se_m: p.se_m,
                }
            }
            Some(_) => LookReading::Flank,
        }
    }

    /// Over the outer elements a flank's pulse (the artery just beyond the array) is
    /// placed inside it at a fraction of the usual amplitude: there a pulse must have the
    /// artery's usual amplitude to be placed; elsewhere it must not be faint.
    fn usual_fraction(&self, r: &Record) -> f64 {
        match r.pulse {
            Some(p) if self.over_outer_elements(p.point.point.z_m - r.at.z_m) => EDGE_FRACTION,
            _ => FAINT_FRACTION,
        }
    }

    fn over_outer_elements(&self, offset_z_m: f64) -> bool {
        offset_z_m.abs() > reach_m(&self.geometry) - 2.0 * self.geometry.pitch_m
    }

    /// Do the amplitudes look like one still artery's kernel? Under breathing the tissue
    /// carries the artery across the still array during a look, and the amplitudes are a
    /// smear no one kernel fits (as `beatslide`'s fixes, at the same false alarm).
    fn fits_one_artery(&self, chi2: f64) -> bool {
        let trusted: f64 = self.geometry.skip_elements.weights().iter().sum();
        let dof = trusted - 4.0;
        dof < 1.0 || chi2 <= chi2_quantile(1.0 - KERNEL_FIT_FALSE_ALARM, dof)
    }

    fn strongest_n(&self) -> f64 {
        self.records
            .iter()
            .filter_map(|r| r.pulse.filter(|p| p.placed).map(|p| p.point.amplitude_n))
            .fold(0.0, f64::max)
    }

    /// The map from every look kept.
    fn rebuild_map(&mut self) {
        let strongest = self.strongest_n();
        let mut map = LineMap::new(&self.region, self.map_settings);
        for r in &self.records {
            map.observe(r.at, self.reading(r, strongest));
        }
        self.map = map;
    }

    /// Analyse the look just ended, update the map and decide.
    fn end_look(&mut self, t: f64, since_s: f64, now: SurfacePoint) -> MotionCommand {
        let at = self.look_place(now);
        self.measure_lag(at);
        let sigma = self
            .noise
            .estimate(self.frames.iter())
            .unwrap_or(self.geometry.noise_sd_n);
        let settings = self.settings();
        let placed = placed_pulse(
            &mut self.pulse_search,
            self.frames.iter(),
            sigma,
            &settings,
            &self.geometry,
        );
        self.looks += 1;
        let mut period = None;
        let pulse = match placed {
            Ok(PlacedPulse {
                found,
                fit,
                sign_margin_chi2,
            }) => {
                let p = found.phase.period_s;
                period = Some(p);
                let rate = fit.snr() / (t - since_s).max(f64::MIN_POSITIVE).sqrt();
                // Only a pulse placed on the inner elements, of known sign: a far lobe's
                // faint pulse must not stretch every look to the limit.
                if fit.amplitude > 0.0
                    && !fit.at_edge
                    && sign_margin_chi2 >= SIGN_MARGIN_CHI2
                    && !self.over_outer_elements(fit.offset_z_m)
                    && rate.is_finite()
                    && self.snr_per_root_s.is_none_or(|r| rate > r)
                {
                    self.snr_per_root_s = Some(rate);
                }
                self.period_s = Some(self.period_s.map_or(p, |old| 0.5 * (old + p)));
                Some(Pulse {
                    point: LocatedPoint {
                        t_s: t,
                        point: SurfacePoint::new(at.x_m, at.z_m + fit.offset_z_m),
                        sensor: at,
                        element: fit.element,
                        amplitude_n: fit.amplitude.abs(),
                        seed: true,
                        sd_m: Some(fit.offset_se_m),
                    },
                    se_m: fit.offset_se_m,
                    placed: !fit.at_edge
                        && sign_margin_chi2 >= SIGN_MARGIN_CHI2
                        && self.fits_one_artery(fit.chi2)
                        && fit.amplitude > 0.0
                        && fit.offset_se_m <= MAX_PLACED_SE_M
                        && (0.0..=(ELEMENTS - 1) as f64).contains(&fit.element),
                })
            }
            Err(_) => {
                let samples = self.frames.len();
                self.shortest_miss_samples = Some(
                    self.shortest_miss_samples
                        .map_or(samples, |s| s.min(samples)),
                );
                None
            }
        };
        let record = Record { at, pulse };
        self.records.push(record);
        self.rebuild_map();
        let felt_point = match self.reading(&record, self.strongest_n()) {
            LookReading::Felt { .. } => pulse.map(|p| p.point),
            _ => None,
        };
        let summary = self.map.summary();
        self.events.push_back(SearchEvent::Look(LookReport {
            t_s: t,
            at,
            duration_s: t - since_s,
            felt: felt_point,
            period_s: period,
            p_present: summary.p_present,
            heading_rad: summary.heading_rad,
            heading_sd_rad: summary.heading_sd_rad,
            looks: self.looks,
        }));
        if self.line_known(summary.p_present)
            && let Some(seeds) = self.seeds()
        {
            self.finish(SearchOutcome::Found {
                t_s: t,
                seeds,
                heading_rad: summary.heading_rad,
                heading_sd_rad: summary.heading_sd_rad,
                p_present: summary.p_present,
                looks: self.looks,
            });
            return MotionCommand::Hold;
        }
        if 1.0 - summary.p_present >= self.params.absent_probability {
            self.not_found(t, NotFoundReason::NothingPulses);
            return MotionCommand::Hold;
        }
        self.next_look(t, at)
    }

    /// Two felt points, not at the array's edge, that agree with the best line and lie at
    /// least `seed_separation_m` apart: the pair farthest apart, ordered along `+x`.
    /// Placed pulses read as the artery's (not faint, not a flank) and felt on the array's
    /// inner elements: the only points a seed may be.
    fn inner_felt(&self) -> Vec<Pulse> {
        let strongest = self.strongest_n();
        self.records
            .iter()
            .filter(|r| matches!(self.reading(r, strongest), LookReading::Felt { .. }))
            .filter_map(|r| r.pulse)
            .filter(|p| !self.over_outer_elements(p.point.point.z_m - p.point.sensor.z_m))
            .collect()
    }

    fn seeds(&self) -> Option<[LocatedPoint; 2]> {
        let (heading, z_c) = self.map.best_line();
        let c = self.region.centre();
        let floor = self.params.place_floor_m;
        let agree: Vec<Pulse> = self
            .inner_felt()
            .into_iter()
            .filter(|f| {
                let z = z_c + heading.tan() * (f.point.point.x_m - c.x_m);
                let sd = f.se_m.hypot(floor);
                (f.point.point.z_m - z).abs() <= AGREE_SIGMAS * sd
            })
            .collect();
        let mut best: Option<(f64, [LocatedPoint; 2])> = None;
        for (i, a) in agree.iter().enumerate() {
            for b in &agree[i + 1..] {
                let dx = a.point.point.distance_to(&b.point.point);
                if dx >= self.params.seed_separation_m && best.is_none_or(|(d, _)| dx > d) {
                    let pair = if a.point.point.x_m <= b.point.point.x_m {
                        [a.point, b.point]
                    } else {
                        [b.point, a.point]
                    };
                    best = Some((dx, pair));
                }
            }
        }
        best.map(|(_, p)| p)
    }

    fn not_found(&mut self, t: f64, reason: NotFoundReason) {
        let samples = self.shortest_miss_samples.unwrap_or(0).max(1) as f64;
        // A pulse of amplitude A on one element, fitted over N samples at σ, has an SE of
        // σ√(2/N): the amplitude at the detection statistic's scale.
        let weakest_felt_n = FELT_SNR * self.geometry.noise_sd_n * (2.0 / samples).sqrt();
        let p_present = self.map.summary().p_present;
        self.finish(SearchOutcome::NotFound {
            t_s: t,
            reason,
            p_present,
            weakest_felt_n,
            looks: self.looks,
        });
    }

    /// Does the map know the line: an artery at least `found_probability` probable
    /// (`p_present`, from the map's summary) and its heading within the tolerance of the
    /// best line's with the configured confidence?
    fn line_known(&self, p_present: f64) -> bool {
        let (heading, _) = self.map.best_line();
        p_present >= self.params.found_probability
            && self
                .map
                .heading_mass_within(heading, self.params.heading_tolerance_rad)
                >= self.params.heading_confidence
    }

    /// Once the map knows the line (an artery to the found probability, its heading to the
    /// configured confidence) but no pair of seeds agrees with it: a look centred on the
    /// line, nearest to `from`, at least the seed separation from any seed felt there
    /// already (so that the next felt point can pair with it). `None` while the
    /// line is not known or no such place lies in the region.
    fn seeding_look(&self, from: SurfacePoint) -> Option<SurfacePoint> {
        if !self.line_known(self.map.summary().p_present) {
            return None;
        }
        let (heading, z_c) = self.map.best_line();
        let inner: Vec<SurfacePoint> = self.inner_felt().iter().map(|p| p.point.point).collect();
        let c = self.region.centre();
        let area = self.region.inset(self.params.edge_margin_m);
        let looked: Vec<SurfacePoint> = self
            .records
            .iter()
            .map(|r| r.at)
            .chain(self.asked.iter().copied())
            .collect();
        // Places along the line, every candidate step, across the whole region.
        let (sin, cos) = heading.sin_cos();
        let half = area.width_m().hypot(area.height_m());
        let steps = (2.0 * half / self.params.candidate_step_m).round().max(1.0) as usize;
        let through = SurfacePoint::new(c.x_m, z_c);
        (0..=steps)
            .map(|i| -half + 2.0 * half * i as f64 / steps as f64)
            .map(|u| SurfacePoint::new(through.x_m + u * cos, through.z_m + u * sin))
            .filter(|p| {
                inner
                    .iter()
                    .all(|s| s.distance_to(p) >= self.params.seed_separation_m)
            })
            .filter(|p| area.contains(*p))
            .filter(|p| !looked.iter().any(|l| l.distance_to(p) < 1e-3))
            .filter(|p| !self.unreachable.iter().any(|u| u.distance_to(p) < 1e-3))
            .min_by(|a, b| from.distance_to(a).total_cmp(&from.distance_to(b)))
    }

    /// Choose the next look and start moving to it.
    fn next_look(&mut self, t: f64, from: SurfacePoint) -> MotionCommand {
        let seeding = self.seeding_look(from);
        let target = match self.method {
            // Both methods, once the line is known, put the array on it to seed.
            _ if seeding.is_some() => seeding,
            plan::SearchMethod::Search => plan::best_look(
                &self.map,
                &self.candidates,
                &self.unreachable,
                &self
                    .records
                    .iter()
                    .map(|r| r.at)
                    .chain(self.asked.iter().copied())
                    .collect::<Vec<_>>(),
                from,
                self.look_s(),
                self.params.speed_m_s,
                self.geometry.pitch_m * 0.1,
                &mut self.scratch,
            )
            .map(|c| c.at),
            plan::SearchMethod::Raster => loop {
                let Some(&p) = self.raster.get(self.raster_next) else {
                    break None;
                };
                self.raster_next += 1;
                if !self.unreachable.iter().any(|u| u.distance_to(&p) < 1e-3) {
                    break Some(p);
                }
            },
        };
        let Some(target) = target else {
            self.not_found(t, NotFoundReason::NothingLeftToLearn);
            return MotionCommand::Hold;
        };
        self.asked.push(target);
        // Aim past the look by the lag measured so far, along the move, so that the sensor
        // itself comes to rest on it; never nearer the region's edge than the margin
        // (a sensor that lags less than measured, or swings across the move, must still
        // stay inside).
        let (dx, dz) = (target.x_m - from.x_m, target.z_m - from.z_m);
        let d = dx.hypot(dz);
        let aim_area = self.region.inset(self.params.edge_margin_m);
        let aim = if d > LAG_MOVE_MIN_M {
            aim_area.clamp(SurfacePoint::new(
                target.x_m + self.lag_m * dx / d,
                target.z_m + self.lag_m * dz / d,
            ))
        } else {
            target
        };
        self.last_target = Some(aim);
        self.moving = Some((from, target));
        self.state = State::Moving { target: aim };
        MotionCommand::MoveTo {
            target: aim,
            speed_m_s: self.params.speed_m_s,
        }
    }

    /// How far the sensor came to rest short of the look just made, along the move to it
    /// (the rod bends, and the tissue's friction holds the sensor back): averaged into the
    /// lag the next moves aim past.
    fn measure_lag(&mut self, at: SurfacePoint) {
        let Some((from, target)) = self.moving.take() else {
            return;
        };
        let (dx, dz) = (target.x_m - from.x_m, target.z_m - from.z_m);
        let d = dx.hypot(dz);
        if d <= LAG_MOVE_MIN_M {
            return;
        }
        let aimed_past = self.lag_m;
        // Short of the aim, in the direction of the move.
        let short = ((target.x_m - at.x_m) * dx + (target.z_m - at.z_m) * dz) / d + aimed_past;
        if short.is_finite() {
            let measured = short.clamp(0.0, MAX_LAG_M);
            self.lag_m = 0.5 * (self.lag_m + measured);
        }
    }
}
