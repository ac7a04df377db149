//! `beatslide` as a state machine fed one tactile frame at a time.
//!
//! Seeding: each [`Tracker::mark`] acquires at rest and searches the window for a pulse of
//! unknown rate ([`PulseSearch`]); a weak pulse extends the window (up to
//! `mark_max_window_s`). The first mark gives the beat clock and the pulse waveform.
//! Tracking, after [`Tracker::start`]: the sensor slides along the path the
//! [`PathFilter`] predicts; once per window of `K` beats (`K` = 1 for a strong pulse) the
//! window is analysed ([`analyse_window`]) and its fix, if the pulse is clear and on the
//! predicted path, is reported, updates the path filter and the beat clock, and sets the
//! next target and speed. Windows that find nothing: the sensor keeps going toward its
//! target for up to `sliding_misses` windows (never more than `max_blind_m` past the last
//! fix), then stops and searches at rest; if that fails it goes back to the last fix and
//! searches there; if that fails too, tracking ends `Lost`, at rest.
//! docs/tracker-beatslide.md describes every rule.

mod lost;
mod marking;
mod replacing;
mod rest_beats;
mod rest_search;
mod seating;
mod sliding;
mod weak;

use replacing::Replaced;
use seating::{SeatedMark, SideMark, Stroke};
use weak::{Listen, ListenFor, WeakStep};

use super::beat_fix::{
    BeatFix, BeatMiss, SpatialPrior, WindowAnalysis, analyse_window, analyse_window_beat_by_beat,
    analyse_window_on_array,
};
use super::drag::Drag;
use super::history::History;
use super::params::BeatSlideParams;
use super::path_filter::{Observation, PathFilter, PathFilterError, PathFilterSettings};
use super::tissue_motion::TissueMotion;
use crate::classify::{ClassifyParams, Kind, Window as ClassifyWindow};
use crate::frames::SurfacePoint;
use crate::sensor::ArrayGeometry;
use crate::signal::beat_clock::{BeatClock, BeatClockSettings};
use crate::signal::detection_bound::chi2_quantile;
use crate::signal::harmonic::{Waveform, waveform_value};
use crate::signal::kernel_fit::{KernelFit, KernelFitError, fit_kernel};
use crate::signal::noise_level::NoiseLevel;
use crate::signal::pulse_search::{PulseFound, PulseSearch, PulseSearchSettings, SearchMiss};
use crate::signal::weak_pulse::Threshold;
use crate::tracker::event_queue::EventQueue;
use crate::tracker::{
    EndReason, LocatedPoint, MotionCommand, PredictedPoint, TrackLimit, Tracker, TrackerError,
    TrackerEvent, TrackerInput, TrackerOutput, TrackerPhase,
};
use crate::types::TactileFrame;

/// The most events one analysis can queue (the held point, a period, a point or a miss, a
/// backtrack or an end).
const EVENTS_PER_ANALYSIS: usize = 4;

/// How far a beat may come early or late against the clock, in periods.
const MAX_DELAY_FRACTION: f64 = 0.25;

/// Samples averaged per block in the search at rest (25 Hz from 100 Hz).
const SEARCH_DECIMATION: usize = 4;

/// Whole cycles a window at rest must hold for a period to be searched.
const MIN_CYCLES: f64 = 2.5;

/// The period change, as a fraction, that is reported as a `Pulse` event.
const PERIOD_REPORT_FRACTION: f64 = 0.02;

/// How far a search at rest looks around the known period (fraction).
const KNOWN_PERIOD_RANGE: f64 = 0.3;

/// Slowest sliding: the travel per fix is never cut below this, m.
const MIN_TRAVEL_PER_FIX_M: f64 = 0.001;

/// The target is never nearer than this along the predicted path, m.
const MIN_LOOKAHEAD_M: f64 = 0.02;

/// A fix weaker than this fraction of the artery's usual SNR is refused.
const USUAL_SNR_FRACTION: f64 = 0.5;

/// A pulse whose amplitude is below this fraction of the artery's usual one is never
/// reported: the kernel's far tail of an artery beyond the array's reach (or a neighbour)
/// fits a weak peak on the array. The artery's own amplitude changes far less than this
/// along a track (depth, tube and contact load change slowly); those seen at the array's
/// edge after a loss were a tenth of it.
const FAINT_FRACTION: f64 = 0.35;

/// A beat later (or earlier) than this many times the usual RMS lateness is refused, but
/// never for less than `MIN_LATE_FRACTION` of a period; the RMS starts at
/// `INITIAL_LATE_FRACTION` of a period.
const LATE_FACTOR: f64 = 4.0;
const MIN_LATE_FRACTION: f64 = 0.08;
const INITIAL_LATE_FRACTION: f64 = 0.05;
/// ... and weaker than this fraction of the usual SNR.
const SPOILED_SNR_FRACTION: f64 = 0.75;

/// A fix this surprising (normalized innovation squared) slows the slide by this factor.
const SURPRISE_NIS: f64 = 4.0;
const SURPRISE_SLOWDOWN: f64 = 0.6;

/// A heart whose beats come off the clock by this fraction of a period (RMS) or more is
/// irregular: a one-beat window too weak to fix is then most often one whose beat came late,
/// and the next analysis spans it (`machine/sliding.rs`). On the tuning families' weak
/// windows this measure ran 0.015-0.06 for regular hearts and 0.06-0.18 for hearts whose
/// interval varies by 5-20 %.
const IRREGULAR_LATE_FRACTION: f64 = 0.05;

/// Speed cap growth per accepted fix after a slowdown.
const SPEED_RECOVERY: f64 = 1.15;

/// Template learning rate from a clear beat.
const TEMPLATE_RATE: f64 = 0.1;

/// Progress along the path that forgives earlier returns, m.
const PROGRESS_M: f64 = 0.005;

/// Why a window or a search found no fix.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum Miss {
    #[error(transparent)]
    Search(#[from] SearchMiss),
    #[error(transparent)]
    Beat(#[from] BeatMiss),
    #[error(transparent)]
    Kernel(#[from] KernelFitError),
    #[error("the pulse lies at the array's edge (element {element:.1})")]
    AtEdge { element: f64 },
    #[error("pulse SNR {snr:.1} is below {needed:.1}")]
    Weak { snr: f64, needed: f64 },
    #[error("the beat came {late_s:.3} s off the clock, far more than usual")]
    Timing { late_s: f64 },
    #[error("not on the predicted path: {0}")]
    OffPath(#[from] PathFilterError),
    #[error("slid the blind distance past the last fix without a fix")]
    Blind,
    #[error("went back to the last fix too often without progress")]
    NoProgress,
    #[error("neither the beat clock nor the window's coherent pattern shows an artery")]
    Untimed,
    #[error("an untimed fix surprised the path model (normalized innovation squared {nis:.1})")]
    UntimedSurprise { nis: f64 },
    #[error("a pulse of {amplitude_n:.4} N is far below this artery's usual {usual_n:.4} N")]
    Faint { amplitude_n: f64, usual_n: f64 },
    #[error("no believed sensor position in the window")]
    NoPosition,
    #[error(
        "the pulse and its inverse fit the kernel about as well (chi-square {margin_chi2:.1} apart): which way it points is not known yet"
    )]
    SignAmbiguous { margin_chi2: f64 },
    #[error("no path model")]
    NoModel,
}

/// Parameters the tracker cannot run with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("beatslide: {0}")]
pub struct InvalidParams(pub String);

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Seeding,
    /// The first mark's seating stroke (`machine/seating.rs`); `plan` is drawn on the first
    /// frame.
    Seating {
        plan: Option<Stroke>,
        frames: u64,
    },
    /// Moving onto an artery a mark felt beyond the array's end (`machine/replacing.rs`),
    /// since `since_s`; `target` is where the sensor should be.
    Replacing {
        target: SurfacePoint,
        since_s: f64,
        frames: u64,
    },
    /// Acquiring at a manual placement since `since_s` (None until the sensor is at rest);
    /// analysed once `window_s` is full.
    Marking {
        since_s: Option<f64>,
        window_s: f64,
    },
    /// Sliding toward `target`; the current window began at `from_s` and lasts `len_s`.
    Sliding {
        from_s: Option<f64>,
        len_s: f64,
        misses: usize,
        /// The window also holds the last one, which missed (an irregular heart's late beat).
        spans_miss: bool,
        target: SurfacePoint,
        speed_m_s: f64,
    },
    /// Holding after losing the pulse, until at rest; then a search (`attempt` 1 here, 2
    /// back at the last fix, 3 a short probe ahead of it: see `machine/lost.rs`).
    Stopping {
        frames: u64,
        attempt: usize,
    },
    Searching {
        since_s: Option<f64>,
        attempt: usize,
    },
    /// Going to where the next search at rest is made (back to the last fix, or the probe
    /// ahead of it). Going back, with `listen_returning`, it listens for the pulse in
    /// windows, the current one from `from_s` (`machine/lost.rs`).
    Returning {
        target: SurfacePoint,
        frames: u64,
        attempt: usize,
        from_s: Option<f64>,
    },
    /// Listening at rest for a weak pulse (`machine/weak.rs`; what for is in `listen`).
    Listening,
    /// Moving to the next stop along a weak artery (`machine/weak.rs`); `attempt` counts
    /// the listens there.
    WeakStepping(WeakStep),
    Finished(EndReason),
}

/// What a mark makes: the seed the path filter sees, the seed point, where the surgeon
/// placed the sensor for it (the direction between placements is the one to follow), and
/// the point reported.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MarkOutcome {
    observation: Observation,
    point: SurfacePoint,
    placement: SurfacePoint,
    located: LocatedPoint,
}

/// The pulse as known so far.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pulse {
    clock: BeatClock,
    template: Waveform,
    /// Peak-to-peak of the unit template (to report amplitudes in N).
    template_pp: f64,
    /// Kernel amplitude SNR one beat gives.
    snr_per_beat: f64,
    /// RMS of the beats' lateness against the clock, s.
    late_rms_s: f64,
    /// The artery's usual pulse amplitude at the kernel's peak, N.
    amplitude_n: f64,
    reported_period_s: f64,
}

/// `beatslide`: one localization per beat while sliding, sub-element, on a curvature path
/// model.
#[derive(Debug, Clone)]
pub struct BeatSlide {
    params: BeatSlideParams,
    geometry: ArrayGeometry,
    history: History,
    noise: NoiseLevel,
    search: PulseSearch,
    untimed: ClassifyWindow,
    pulse: Option<Pulse>,
    spatial: SpatialPrior,
    drag: Drag,
    /// The seed marks as the path filter sees them, and as reported.
    seeds: Vec<Observation>,
    seed_points: Vec<SurfacePoint>,
    seed_sensors: Vec<SurfacePoint>,
    /// The first placement, where the seating strokes return to, and its mark made from
    /// the first side while the second is made (`machine/seating.rs`).
    seat_home: Option<SurfacePoint>,
    first_side: Option<SideMark>,
    /// This mark's outcome at its placement while it moves onto an artery felt beyond the
    /// array's end and marks again (`machine/replacing.rs`).
    replaced: Option<Replaced>,
    filter: Option<PathFilter>,
    /// The artery's motion across its course that the path model does not explain.
    tissue: TissueMotion,
    /// The artery as re-found back at the last fix, while probing ahead of it.
    anchor: Option<Observation>,
    last_fix: Option<SurfacePoint>,
    path_length_m: f64,
    progress_mark_m: f64,
    returns: usize,
    beats_per_fix: usize,
    speed_cap_m_s: f64,
    limit: TrackLimit,
    state: State,
    pending_end: Option<EndReason>,
    events: EventQueue,
    rejected_frames: u64,
    /// The pulse amplitude of the last fix offered for reporting, N (NaN before one).
    previous_amplitude_n: f64,
    /// A point located while sliding, held until the next window says whether the artery
    /// was still under the array (`hold`).
    held: Option<LocatedPoint>,
    /// Where the arm's load puts the sensor across its motion, off the belief and the lag
    /// (the rod's deflection the tilt and lag models do not hold), smoothed over windows.
    felt_across: Option<[f64; 2]>,
    last_miss: Option<Miss>,
    /// The weak-pulse listen in progress, its threshold (`None`: listening is off), and
    /// whether a seed came from one (the artery is then tracked by listening).
    listen: Option<Listen>,
    weak_threshold: Option<Threshold>,
    weak_artery: bool,
}

/// Smallest share of the lower of this artery's usual amplitude and the last fix's at
/// which a point located while tracking is reported (fixes down to `FAINT_FRACTION` of the
/// usual still steer). Chosen on the tuning seeds: 19 of 32 points more than 2 mm off left,
/// at 1.3 % of the points (docs/BENCHMARKS.md).
const REPORT_FRACTION: f64 = 0.7;
/// Within this many pitches of an outer element's centre a reported fix needs
/// `FLANK_FRACTION` of the usual amplitude (chosen on the tuning seeds: 0.8 within one pitch
/// left out 0.3 % of the points and 2 of 8 more than 2 mm off; 0.85-0.9, or 1.5 pitches,
/// left out up to 1.6 % for no more).
const FLANK_ELEMENTS: f64 = 1.0;
const FLANK_FRACTION: f64 = 0.8;

/// A point whose artery lay more than this many elements from the last fix's place on the
/// array is not reported (it steers): the artery crossed the array within the window (the
/// tissue moving, a rod swinging), and the fit placed a smear. Chosen on the tuning seeds
/// 1001-1060 among 1.2, 1.5 and 2: at 2 it took out 1.6 % of the points, 5 of 55 more than
/// 1 mm off and 2 of 8 more than 1.5 mm (1.5 and 1.2 took out 8 % and 14 % for 4 and 5 of
/// the 8); docs/BENCHMARKS.md, "A point waits for the next window".
const MAX_REPORTED_SWEEP_ELEMENTS: f64 = 2.0;

/// Tissue motion SDs a reported point's centre must lie inside the outer elements' centres.
const EDGE_MOTION_SDS: f64 = 1.0;

/// False alarm of the one-kernel test on a reported fix ([`BeatSlide::fits_one_artery`]).
const KERNEL_FIT_FALSE_ALARM: f64 = 1e-3;

/// Most seed points kept.
const MAX_SEEDS: usize = 16;
/// Largest tissue motion SD added to a fix's: with the gate at 4 SD, more would let in a
/// pulse 8 mm beside the course.
const MAX_TISSUE_SD_M: f64 = 0.002;
/// Tissue motion beyond which a window of several beats is not reported as a point, m.
const SMEAR_SD_M: f64 = 0.0005;
/// The last frames before the track starts (at rest on the last placement) over which
/// the load reads the lag, s.
const REST_LOAD_WINDOW_S: f64 = 1.0;
/// A point more than this from the artery is a false point (issue 13's rule), m.
const FALSE_POINT_M: f64 = 0.002;
/// Standard errors of its own fit within which a point must lie inside `FALSE_POINT_M` to
/// be reported ([`vouched_within_false_point`]).
const VOUCH_SES: f64 = 3.0;
/// The arm's load reads the sensor's lag while sliding to within this (its scatter there
/// is 0.3-0.6 mm RMS frame to frame; over a window the joints' friction leaves a bias of
/// a few tenths), m.
const LOAD_LAG_SD_M: f64 = 0.0005;
/// Weight of each window's reading in the smoothed offset across the motion
/// (`BeatSlide::felt_across`): an exponential average over about two windows, since one
/// window's reading scatters by 0.3-1 mm. Chosen on the tuning seeds (1001-1060) between
/// 0.3 and 0.5; reading each window alone (1) reported more points off.
const FELT_ACROSS_WEIGHT: f64 = 0.5;
/// The lag's direction over a window must be at least this steady (the mean of its unit
/// directions) for the load's reading to be taken as the lag's.
const LOAD_LAG_MIN_DIRECTION: f64 = 0.9;

impl BeatSlide {
    pub const NAME: &'static str = "beatslide";

    /// Build the tracker; allocates every buffer it will use.
    pub fn new(params: BeatSlideParams, geometry: ArrayGeometry) -> Result<Self, InvalidParams> {
        geometry.check().map_err(InvalidParams)?;
        let fs = geometry.sample_rate_hz;
        check_params(&params, fs)?;
        let longest_s = params.mark_max_window_s.max(params.search_window_s).max(
            params.max_beats_per_fix as f64 * params.max_period_s * (1.0 + MAX_DELAY_FRACTION),
        );
        let capacity = (longest_s * fs * 1.1).ceil() as usize + 16;
        let weak_threshold = weak::weak_threshold(&params, &geometry)?;
        Ok(Self {
            params,
            geometry,
            history: History::new(capacity),
            noise: NoiseLevel::new(capacity),
            search: PulseSearch::new(capacity),
            untimed: ClassifyWindow::new(capacity),
            pulse: None,
            spatial: SpatialPrior {
                element: 4.5,
                width_m: 0.005,
            },
            drag: Drag::default(),
            seeds: Vec::with_capacity(MAX_SEEDS),
            seed_points: Vec::with_capacity(MAX_SEEDS),
            seed_sensors: Vec::with_capacity(MAX_SEEDS),
            seat_home: None,
            replaced: None,
            first_side: None,
            filter: None,
            tissue: TissueMotion::new(MAX_TISSUE_SD_M),
            anchor: None,
            last_fix: None,
            path_length_m: 0.0,
            progress_mark_m: 0.0,
            returns: 0,
            beats_per_fix: 1,
            speed_cap_m_s: params.max_speed_m_s,
            limit: TrackLimit::default(),
            state: State::Seeding,
            pending_end: None,
            events: EventQueue::default(),
            rejected_frames: 0,
            previous_amplitude_n: f64::NAN,
            held: None,
            felt_across: None,
            last_miss: None,
            listen: None,
            weak_threshold,
            weak_artery: false,
        })
    }

    pub fn params(&self) -> &BeatSlideParams {
        &self.params
    }

    /// The beat clock's period, s.
    pub fn period_estimate_s(&self) -> Option<f64> {
        self.pulse.map(|p| p.clock.period_s())
    }

    /// Beats averaged into each fix now.
    pub fn beats_per_fix(&self) -> usize {
        self.beats_per_fix
    }

    /// The path model.
    pub fn path_filter(&self) -> Option<&PathFilter> {
        self.filter.as_ref()
    }

    /// Path length along the located points from the first seed, m.
    pub fn path_length_m(&self) -> f64 {
        self.path_length_m
    }

    /// Frames refused (non-finite).
    pub fn rejected_frames(&self) -> u64 {
        self.rejected_frames
    }

    /// Why the last window or search found nothing.
    pub fn last_miss(&self) -> Option<Miss> {
        self.last_miss
    }

    /// Report a point located while tracking (its fit `fit`), if the array felt it as one
    /// artery at this artery's strength: its amplitudes fit one kernel
    /// ([`Self::fits_one_artery`]); its centre lay under the array, between the outer
    /// elements' centres (beyond them the array felt only a flank and the place is
    /// extrapolated), and under moving tissue a motion SD inside them; and its pulse was
    /// near this artery's usual amplitude and the last fix's (a pulse well below both was
    /// felt smeared, the artery moving under the beat, or from its edge). Such a fix
    /// steers, unreported. (A mark's point is its result and is always reported, with its
    /// SD.)
    ///
    /// `sweep_elements`: how far the artery moved across the array within the fix's window,
    /// in elements (0 at rest).
    fn report(&mut self, located: LocatedPoint, fit: &KernelFit, sweep_elements: f64) {
        if self.reportable(&located, fit, sweep_elements) {
            self.emit(TrackerEvent::Located(located));
        }
    }

    /// A point located while sliding is reported only once the next window has given a fix:
    /// a window the artery was leaving the array in (a bend, a weak irregular beat) is
    /// placed by the one flank still felt, and the next window then misses it. On the fresh
    /// draws 13001-13060 every one of the four points more than 2 mm off while sliding was
    /// the last before a miss (docs/BENCHMARKS.md, "A point waits for the next window").
    /// A miss drops the held point; a fix, or an end that is not a loss, reports it.
    fn hold(&mut self, located: LocatedPoint, fit: &KernelFit, sweep_elements: f64) {
        if self.reportable(&located, fit, sweep_elements) {
            self.held = Some(located);
        }
    }

    /// The held point is confirmed: report it.
    fn release_held(&mut self) {
        if let Some(p) = self.held.take() {
            self.emit(TrackerEvent::Located(p));
        }
    }

    /// Does a located point pass the checks for being reported (one artery's pulse, placed
    /// well within the array, not swept across it, at this artery's amplitude)? A point
    /// that gets as far as the amplitude check leaves its amplitude as the next one's
    /// reference (`previous_amplitude_n`).
    fn reportable(&mut self, located: &LocatedPoint, fit: &KernelFit, sweep_elements: f64) -> bool {
        if !self.fits_one_artery(fit)
            || !vouched_within_false_point(fit)
            || sweep_elements > MAX_REPORTED_SWEEP_ELEMENTS
        {
            return false;
        }
        // Under moving tissue the artery moves by about the motion's SD within a window, and
        // while sliding across a bend by its sweep: a centre within half of that of the outer
        // elements may have been beyond them for part of the window, felt by one flank.
        let margin = (EDGE_MOTION_SDS * self.tissue.sd_m() / self.geometry.pitch_m)
            .max(0.5 * sweep_elements);
        let last = (crate::types::ELEMENTS - 1) as f64 - margin;
        // Against the usual amplitude or the last fix's, the lower: a pulse fading along
        // the artery (an occlusion) fades fix by fix and stays reported; a beat felt
        // smeared is a dip below both.
        let usual_n = self.pulse.map_or(0.0, |p| p.amplitude_n);
        // Within a pitch of the outer elements' centres the fit has one flank to go by and
        // trades amplitude for place: a centre pulled in from beyond the end shows as a
        // weaker pulse. There the usual amplitude alone is the reference, and more of it.
        let outer = (crate::types::ELEMENTS - 1) as f64;
        let needed_n = if located.element.min(outer - located.element) < FLANK_ELEMENTS {
            FLANK_FRACTION * usual_n
        } else {
            REPORT_FRACTION * usual_n.min(self.previous_amplitude_n)
        };
        self.previous_amplitude_n = located.amplitude_n;
        (margin..=last).contains(&located.element) && located.amplitude_n >= needed_n
    }

    fn emit(&mut self, event: TrackerEvent) {
        // Room for a whole analysis is checked before each one; overflow would mean that
        // accounting is broken.
        let pushed = self.events.push(event);
        debug_assert!(pushed.is_ok(), "tracker event queue overflow");
    }

    fn finish(&mut self, reason: EndReason, t_s: f64) {
        if reason == EndReason::Lost {
            self.held = None;
        } else {
            self.release_held();
        }
        self.state = State::Finished(reason);
        self.emit(TrackerEvent::Finished { t_s, reason });
    }

    /// Take the pulse's rate, phase and waveform from a search at rest.
    fn learn_pulse(&mut self, found: &PulseFound, fit: &KernelFit, window_s: f64, t_s: f64) {
        let settings = BeatClockSettings {
            min_period_s: self.params.min_period_s,
            max_period_s: self.params.max_period_s,
            ..BeatClockSettings::default()
        };
        let beats = (window_s / found.phase.period_s).max(1.0);
        let snr_per_beat = fit.snr() / beats.sqrt();
        let pulse = match self.pulse {
            None => Pulse {
                clock: BeatClock::new(found.phase, settings),
                template: found.waveform,
                template_pp: peak_to_peak(&found.waveform),
                snr_per_beat,
                late_rms_s: INITIAL_LATE_FRACTION * found.phase.period_s,
                amplitude_n: fit.amplitude * peak_to_peak(&found.waveform),
                reported_period_s: f64::NAN,
            },
            Some(mut p) => {
                p.clock.reset(found.phase);
                let blended = p.template + found.waveform;
                let norm = blended.norm();
                if norm > 0.0 {
                    p.template = blended / norm;
                    p.template_pp = peak_to_peak(&p.template);
                }
                p.snr_per_beat = 0.5 * (p.snr_per_beat + snr_per_beat);
                p
            }
        };
        self.pulse = Some(pulse);
        self.spatial = SpatialPrior {
            element: fit.element,
            width_m: fit.width_m,
        };
        self.choose_beats_per_fix();
        self.report_period(t_s);
    }

    /// A fit's pulse amplitude in N (peak to peak of the learned waveform at the kernel's
    /// peak; in the fit's own units before a waveform is known).
    fn amplitude_n(&self, fit: &KernelFit) -> f64 {
        fit.amplitude * self.pulse.map_or(1.0, |p| p.template_pp)
    }

    /// Refuse a pulse far weaker than this artery's usual one (no usual one yet: anything).
    fn check_amplitude(&self, fit: &KernelFit) -> Result<(), Miss> {
        let Some(p) = self.pulse else {
            return Ok(());
        };
        let amplitude_n = self.amplitude_n(fit);
        if amplitude_n.is_nan() || amplitude_n < FAINT_FRACTION * p.amplitude_n {
            return Err(Miss::Faint {
                amplitude_n,
                usual_n: p.amplitude_n,
            });
        }
        Ok(())
    }

    fn report_period(&mut self, t_s: f64) {
        if let Some(p) = &mut self.pulse {
            let period_s = p.clock.period_s();
            let reported = p.reported_period_s;
            if !(reported.is_finite()
                && ((period_s - reported) / reported).abs() < PERIOD_REPORT_FRACTION)
            {
                p.reported_period_s = period_s;
                self.emit(TrackerEvent::Pulse { t_s, period_s });
            }
        }
    }

    fn choose_beats_per_fix(&mut self) {
        if let Some(p) = self.pulse {
            let snr = p.snr_per_beat.max(1e-3);
            let k = (self.params.target_snr / snr).powi(2).ceil();
            self.beats_per_fix = (k.max(1.0) as usize).min(self.params.max_beats_per_fix);
        }
    }

    fn located(
        &self,
        t_s: f64,
        point: SurfacePoint,
        sensor: SurfacePoint,
        fit: &KernelFit,
        seed: bool,
        sd_m: f64,
    ) -> LocatedPoint {
        LocatedPoint {
            t_s,
            point,
            sensor,
            element: fit.element,
            amplitude_n: self.amplitude_n(fit),
            seed,
            sd_m: Some(sd_m),
        }
    }

    /// A reported point's SD across the artery: its observation's (`fix_sd_m`) and that of
    /// the lag it was corrected by along `lag_dir`. With a path model, only the lag's part
    /// across the path's heading counts (sliding along the artery, an error in the lag moves
    /// the point along it); before one (the seeds), all of it, and the prior's SD.
    fn point_sd(&self, fix_sd_m: f64, lag_dir: [f64; 2]) -> f64 {
        let lag_across = match self.filter.as_ref() {
            Some(f) => {
                let (sin, cos) = f.heading_rad().sin_cos();
                f.lag_sd_m() * (-lag_dir[0] * sin + lag_dir[1] * cos).abs()
            }
            None => self.params.lag_prior_sd_m * lag_dir[0].hypot(lag_dir[1]),
        };
        fix_sd_m.hypot(lag_across)
    }

    /// The lateral SD of a fix for the path filter. Beyond the outer elements' centres the
    /// position is extrapolated from a flank: that distance counts as uncertainty too.
    fn fix_sd(&self, fit: &KernelFit) -> f64 {
        let last = (crate::types::ELEMENTS - 1) as f64;
        let outside = (-fit.element).max(fit.element - last).max(0.0) * self.geometry.pitch_m;
        fit.offset_se_m
            .hypot(self.params.fix_floor_m)
            .hypot(outside)
    }

    /// A window longer than a beat averages the artery over the tissue's motion: it gives
    /// where the artery lay on average, not where it lay at any one time. Once the tissue
    /// is seen to move, such a fix steers the track but is not reported as a point.
    fn smeared(&self, window_s: f64) -> bool {
        let period = self.pulse.map_or(1.0, |p| p.clock.period_s());
        self.tissue_moving() && window_s > 1.5 * period
    }

    /// Is the tissue seen to move under the sensor (beyond `SMEAR_SD_M`)?
    fn tissue_moving(&self) -> bool {
        self.tissue.sd_m() > SMEAR_SD_M
    }

    /// Do a fix's amplitudes look like one artery's kernel? Over a beat in which the artery
    /// swept along the array (tissue moving with breathing, the course crossing the
    /// elements' line at a shallow angle) the amplitudes are a smear that no one kernel
    /// fits, and its fitted place was 2-4 mm from where the artery lay at any moment. The
    /// fit's chi-square against its degrees of freedom (the trusted elements less the
    /// kernel's four parameters), at a false alarm of `KERNEL_FIT_FALSE_ALARM` on a still
    /// artery: such a fix steers the track but is not reported.
    fn fits_one_artery(&self, fit: &KernelFit) -> bool {
        let trusted: f64 = self.geometry.skip_elements.weights().iter().sum();
        let dof = trusted - 4.0;
        dof < 1.0 || fit.chi2 <= chi2_quantile(1.0 - KERNEL_FIT_FALSE_ALARM, dof)
    }

    /// Where the arm's load puts a point that the tracker placed at `point` from a window
    /// whose believed sensor positions put it at `raw` (before the lag was removed):
    /// `Some` only when the load was read over the whole window and the two places are
    /// more than `load_gate_m` apart (across the path, once there is a path model: along
    /// it a place error moves the point along the artery, not off it).
    fn load_disagrees(
        &self,
        raw: SurfacePoint,
        point: SurfacePoint,
        felt: Option<[f64; 2]>,
    ) -> Option<SurfacePoint> {
        let loaded = self.load_place(raw, felt)?;
        let (dx, dz) = (loaded.x_m - point.x_m, loaded.z_m - point.z_m);
        let apart = match self.filter.as_ref() {
            Some(f) => {
                let (sin, cos) = f.heading_rad().sin_cos();
                (-dx * sin + dz * cos).abs()
            }
            None => dx.hypot(dz),
        };
        (apart > self.params.load_gate_m).then_some(loaded)
    }

    /// Where the arm's load puts a point whose window's believed sensor positions put it at
    /// `raw`: `raw` moved by the window's felt offset, if the load was read over the whole
    /// window and the reading is used (`load_gate_m` > 0).
    fn load_place(&self, raw: SurfacePoint, felt: Option<[f64; 2]>) -> Option<SurfacePoint> {
        let felt = felt.filter(|_| self.params.load_gate_m > 0.0)?;
        Some(SurfacePoint::new(raw.x_m + felt[0], raw.z_m + felt[1]))
    }

    /// A point found at rest over the window since `since`, placed at `raw` from the believed
    /// `sensor`: where the arm's load puts the point and the sensor, if it was read over the
    /// whole window. At rest that reading is within 0.1-0.3 mm, the better of the two
    /// (docs/tracker-beatslide.md, "Where the arm's load puts the sensor").
    fn placed_at_rest(
        &self,
        since: f64,
        raw: SurfacePoint,
        sensor: SurfacePoint,
    ) -> Option<(SurfacePoint, SurfacePoint)> {
        let felt = self.history.since(since).mean_felt_offset();
        Some((self.load_place(raw, felt)?, self.load_place(sensor, felt)?))
    }

    fn record(&mut self, point: SurfacePoint) {
        if let Some(previous) = self.last_fix {
            self.path_length_m += previous.distance_to(&point);
        }
        self.last_fix = Some(point);
        if self.path_length_m > self.progress_mark_m + PROGRESS_M {
            self.returns = 0;
        }
    }

    fn length_reached(&self) -> bool {
        self.limit
            .length_m
            .is_some_and(|length_m| self.path_length_m >= length_m)
    }

    // ---- seeding ----

    /// A search at rest (a mark or a search after a loss): `since_s`, when the sensor came to
    /// rest, is restarted whenever it moves; the window's start once `window_s` of rest is
    /// in and the event queue has room for the analysis.
    fn rest_window(
        &self,
        input: &TrackerInput<'_>,
        since_s: &mut Option<f64>,
        window_s: f64,
    ) -> Option<f64> {
        let t = input.frame.t_s;
        if !input.settled || !input.sensor.is_finite() {
            *since_s = None;
            return None;
        }
        let since = *since_s.get_or_insert(t);
        (t - since + 1e-9 >= window_s && self.events.has_room_for(EVENTS_PER_ANALYSIS))
            .then_some(since)
    }

    /// The frame as the analyses read it: skipped elements read as nothing, so no search
    /// or fit sees a stuck or saturated element's signal and the kernel fit weighs them not
    /// at all.
    fn trusted_frame(&self, frame: &TactileFrame) -> TactileFrame {
        let mut frame = *frame;
        for (e, f) in frame.force_n.iter_mut().enumerate() {
            if self.geometry.skip_elements.contains(e) {
                *f = 0.0;
            }
        }
        frame
    }

    fn motion(&self) -> MotionCommand {
        match self.state {
            State::Sliding {
                target, speed_m_s, ..
            } => MotionCommand::MoveTo {
                target: self.belief_from_sensor(target),
                speed_m_s,
            },
            State::Returning { target, .. } => MotionCommand::MoveTo {
                target: self.belief_from_sensor(target),
                speed_m_s: self.params.return_speed_m_s,
            },
            State::WeakStepping(WeakStep {
                target,
                holding: false,
                ..
            })
            | State::Replacing { target, .. } => MotionCommand::MoveTo {
                target: self.belief_from_sensor(target),
                speed_m_s: self.params.return_speed_m_s,
            },
            State::Seating {
                plan: Some(stroke), ..
            } => MotionCommand::MoveTo {
                target: self.belief_from_sensor(stroke.target()),
                speed_m_s: self.params.return_speed_m_s,
            },
            _ => MotionCommand::Hold,
        }
    }

    /// Where the sensor is for a believed position: pushed outward from the point below
    /// the pivot (the tissue origin) by the tilt deflection.
    fn sensor_from_belief(&self, believed: SurfacePoint) -> SurfacePoint {
        let g = 1.0 + self.params.tilt_deflection;
        SurfacePoint::new(believed.x_m * g, believed.z_m * g)
    }

    /// The believed position that puts the sensor at `sensor`.
    fn belief_from_sensor(&self, sensor: SurfacePoint) -> SurfacePoint {
        let g = 1.0 + self.params.tilt_deflection;
        SurfacePoint::new(sensor.x_m / g, sensor.z_m / g)
    }
}

/// Can a fix vouch for its place to within a false point's distance? Its fit's own SE of
/// place, times `VOUCH_SES`, must be within `FALSE_POINT_M`: beyond that the fit alone
/// leaves a chance above 0.3 % that the artery lay more than 2 mm away. A fix that cannot
/// still steers the track; it is not reported. On the fresh families (9001-9060) one fix
/// in 650 is refused so; the one whose point had been 7.65 mm off among them (an SE of
/// 0.96 mm: a weak pulse near the array's end after the course was lost).
fn vouched_within_false_point(fit: &KernelFit) -> bool {
    fit.offset_se_m * VOUCH_SES <= FALSE_POINT_M
}

/// The path filter's settings from the tracker's.
pub(super) fn filter_settings(p: &BeatSlideParams) -> PathFilterSettings {
    PathFilterSettings {
        offset_prior_m: 0.002,
        slope_prior: 0.3,
        curvature_prior_per_m: p.curvature_prior_per_m,
        curvature_walk: p.curvature_walk,
        turning_walk: p.turning_walk,
        turn_onset: p.turn_onset,
        turn_end: p.turn_end,
        lag_prior_m: p.lag_prior_m,
        lag_prior_sd_m: p.lag_prior_sd_m,
        lag_walk: p.lag_walk,
        gate_sigma: p.gate_sigma,
        gate_min_m: p.gate_min_m,
    }
}

/// Peak-to-peak of a waveform over one cycle.
fn peak_to_peak(w: &Waveform) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..128 {
        let v = waveform_value(w, k as f64 * std::f64::consts::TAU / 128.0);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if hi > lo { hi - lo } else { 1.0 }
}

fn check_params(p: &BeatSlideParams, fs: f64) -> Result<(), InvalidParams> {
    let positive = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(InvalidParams(format!("{name} must be positive, got {v}")))
        }
    };
    for (name, v) in [
        ("min_period_s", p.min_period_s),
        ("max_period_s", p.max_period_s),
        ("detection_threshold", p.detection_threshold),
        ("coherent_s", p.coherent_s),
        ("mark_window_s", p.mark_window_s),
        ("mark_extend_s", p.mark_extend_s),
        ("mark_max_window_s", p.mark_max_window_s),
        ("search_window_s", p.search_window_s),
        ("fix_snr", p.fix_snr),
        ("target_snr", p.target_snr),
        ("max_speed_m_s", p.max_speed_m_s),
        ("max_travel_per_fix_m", p.max_travel_per_fix_m),
        ("prediction_sd_m", p.prediction_sd_m),
        ("max_blind_m", p.max_blind_m),
        ("gate_sigma", p.gate_sigma),
        ("gate_min_m", p.gate_min_m),
        ("curvature_prior_per_m", p.curvature_prior_per_m),
        ("curvature_walk", p.curvature_walk),
        ("fix_floor_m", p.fix_floor_m),
        ("return_speed_m_s", p.return_speed_m_s),
    ] {
        positive(name, v)?;
    }
    // A stroke longer than the array's travel is a typo, not a seating.
    if !(0.0..=0.05).contains(&p.seat_stroke_m) {
        return Err(InvalidParams(format!(
            "seat_stroke_m must be in [0, 0.05] m, got {}",
            p.seat_stroke_m
        )));
    }
    // Wider than the array's reach the gate could never close.
    if !(0.0..=0.01).contains(&p.load_gate_m) {
        return Err(InvalidParams(format!(
            "load_gate_m must be in [0, 0.01] m, got {}",
            p.load_gate_m
        )));
    }
    // A switch of more than one half would make the modes anti-persistent.
    if !(p.turning_walk.is_finite() && p.turning_walk >= 0.0) {
        return Err(InvalidParams(format!(
            "turning_walk must be 0 (one mode) or positive, got {}",
            p.turning_walk
        )));
    }
    for (name, v) in [("turn_onset", p.turn_onset), ("turn_end", p.turn_end)] {
        if !(v > 0.0 && v <= 0.5) {
            return Err(InvalidParams(format!(
                "{name} must be in (0, 0.5], got {v}"
            )));
        }
    }
    // A negative deflection of a whole unit would map every position onto the origin.
    if !(0.0..0.5).contains(&p.tilt_deflection) {
        return Err(InvalidParams(format!(
            "tilt_deflection must be in [0, 0.5), got {}",
            p.tilt_deflection
        )));
    }
    if p.min_period_s >= p.max_period_s {
        return Err(InvalidParams(format!(
            "min_period_s {} must be below max_period_s {}",
            p.min_period_s, p.max_period_s
        )));
    }
    if 2.0 / p.min_period_s * 3.0 >= fs {
        return Err(InvalidParams(format!(
            "the third harmonic of the fastest pulse ({:.1} Hz) needs a frame rate above {:.1} Hz, got {fs} Hz",
            3.0 / p.min_period_s,
            6.0 / p.min_period_s
        )));
    }
    if p.mark_max_window_s < p.mark_window_s {
        return Err(InvalidParams(
            "mark_max_window_s must be at least mark_window_s".into(),
        ));
    }
    if p.mark_window_s < MIN_CYCLES * p.min_period_s
        || p.search_window_s < MIN_CYCLES * p.min_period_s
    {
        return Err(InvalidParams(format!(
            "windows at rest must hold {MIN_CYCLES} cycles of the fastest pulse ({:.2} s)",
            MIN_CYCLES * p.min_period_s
        )));
    }
    if p.mark_max_window_s > 120.0 || p.search_window_s > 120.0 {
        return Err(InvalidParams("windows at rest are limited to 120 s".into()));
    }
    if !(1..=64).contains(&p.max_beats_per_fix) {
        return Err(InvalidParams(format!(
            "max_beats_per_fix must be 1 to 64, got {}",
            p.max_beats_per_fix
        )));
    }
    if p.sliding_misses == 0 {
        return Err(InvalidParams("sliding_misses must be at least 1".into()));
    }
    Ok(())
}

/// Points of the path ahead drawn for display, from the last fix to `max_blind_m`.
const PATH_AHEAD_POINTS: usize = 16;

impl Tracker for BeatSlide {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    /// The path filter's course from the last fix to as far as the tracker would go blind,
    /// with its lateral SD (growing with distance); empty before tracking and after it.
    fn path_ahead(&self, out: &mut Vec<PredictedPoint>) {
        out.clear();
        let Some(filter) = self.filter.as_ref() else {
            return;
        };
        if self.phase() != TrackerPhase::Tracking {
            return;
        }
        let last = (PATH_AHEAD_POINTS - 1) as f64;
        out.extend((0..PATH_AHEAD_POINTS).filter_map(|i| {
            let p = filter.predict(self.params.max_blind_m * i as f64 / last);
            p.point.is_finite().then_some(PredictedPoint {
                point: p.point,
                sd_m: Some(p.sd_m),
            })
        }));
    }

    fn phase(&self) -> TrackerPhase {
        if let Some(reason) = self.pending_end {
            return TrackerPhase::Finished(reason);
        }
        match self.state {
            State::Seeding => TrackerPhase::Seeding {
                seeds: self.seeds.len(),
            },
            State::Marking { .. } | State::Seating { .. } | State::Replacing { .. } => {
                TrackerPhase::Marking
            }
            State::Listening => match self.listen.as_ref().map(|l| l.purpose) {
                Some(ListenFor::Mark) => TrackerPhase::Marking,
                _ => TrackerPhase::Tracking,
            },
            State::Sliding { .. }
            | State::Stopping { .. }
            | State::Searching { .. }
            | State::Returning { .. }
            | State::WeakStepping(_) => TrackerPhase::Tracking,
            State::Finished(reason) => TrackerPhase::Finished(reason),
        }
    }

    fn mark(&mut self) -> Result<(), TrackerError> {
        match self.phase() {
            TrackerPhase::Seeding { .. } => {
                self.first_side = None;
                self.seat_home = None;
                self.replaced = None;
                self.listen = None;
                if self.seeds.is_empty() {
                    self.weak_artery = false;
                }
                if self.seeds.is_empty() && self.params.seat_stroke_m > 0.0 {
                    self.state = State::Seating {
                        plan: None,
                        frames: 0,
                    };
                } else {
                    self.begin_marking();
                }
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
        let n = self.seeds.len();
        if n < 2 {
            return Err(TrackerError::NotSeeded { have: n });
        }
        if let Some(length_m) = limit.length_m
            && !(length_m.is_finite() && length_m > 0.0)
        {
            return Err(TrackerError::BadLimit(format!(
                "length_m must be positive, got {length_m}"
            )));
        }
        // How far apart the surgeon placed the sensor: the located points can be closer
        // (the first mark's lag is unknown, as its approach was not seen), and their
        // uncertainty is in the filter's observations.
        let spacing_m = self.seed_sensors[n - 2].distance_to(&self.seed_sensors[n - 1]);
        let settings = filter_settings(&self.params);
        let too_close = TrackerError::SeedsTooClose {
            distance_m: spacing_m,
            min_m: self.geometry.pitch_m,
        };
        if spacing_m < self.geometry.pitch_m {
            return Err(too_close);
        }
        // The surgeon moved the sensor along the artery between the placements: that is the
        // direction to follow (a located point may lie at the array's edge).
        let (first, last) = (self.seed_sensors[0], self.seed_sensors[n - 1]);
        let heading = if first.distance_to(&last) >= self.geometry.pitch_m {
            (last.z_m - first.z_m).atan2(last.x_m - first.x_m)
        } else {
            f64::NAN
        };
        let filter = PathFilter::from_observations(&self.seeds, heading, settings)
            .map_err(|_| too_close.clone())?;
        self.filter = Some(filter);
        // At rest after the approach to the last placement, friction holds the rod's
        // deflection along that approach: the load reads it before the first slide.
        self.felt_across = None;
        if let Some(t) = self.history.newest_t_s() {
            self.read_deflection_from_load(t - REST_LOAD_WINDOW_S);
        }
        self.tissue.clear();
        self.limit = limit;
        // The length tracked counts from the first placement. Between the marks it is
        // measured on the placements, not on the located points: both marks were made at
        // rest after the surgeon's placing, but only the second one's approach was seen, so
        // only its lag is removed, and the points' spacing is short by the first one's lag
        // (4.5 mm, nearly a sixth of the radial wrist's 28 mm track, in the simulator).
        self.path_length_m = self
            .seed_sensors
            .windows(2)
            .map(|w| w[0].distance_to(&w[1]))
            .sum();
        self.last_fix = self.seed_points.last().copied();
        self.progress_mark_m = self.path_length_m;
        if self.length_reached() {
            self.pending_end = Some(EndReason::LengthReached);
            return Ok(());
        }
        let from = self.seed_points[n - 1];
        // A weak artery is followed by listening at stops (`machine/weak.rs`), from where
        // the sensor stands.
        self.state = if self.weak_artery {
            self.weak_step_from(self.seed_sensors[n - 1])
        } else {
            self.sliding_from(from)
        }
        .ok_or(too_close)?;
        Ok(())
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
        // From here on every position is where the sensor truly is (as far as the tilt
        // model knows); the moves are turned back into the robot's belief in `motion`.
        let compensated = TrackerInput {
            frame: input.frame,
            sensor: self.sensor_from_belief(input.sensor),
            settled: input.settled,
            loaded_sensor: input.loaded_sensor,
        };
        let input = &compensated;
        let t_s = input.frame.t_s;
        if let Some(reason) = self.pending_end.take() {
            self.finish(reason, t_s);
        }
        if input.frame.is_finite() && input.sensor.is_finite() {
            let lag = self
                .filter
                .as_ref()
                .map_or(self.params.lag_prior_m, PathFilter::lag_m);
            let lag_dir = self.drag.update(input.sensor, lag);
            if self.history.newest_t_s().is_none_or(|last| t_s > last) {
                let frame = self.trusted_frame(input.frame);
                self.history
                    .push(frame, input.sensor, lag_dir, input.loaded_sensor);
            } else {
                self.rejected_frames += 1;
            }
        } else {
            self.rejected_frames += 1;
        }
        match self.state {
            State::Seeding | State::Finished(_) => {}
            State::Seating { plan, frames } => self.step_seating(input, plan, frames),
            State::Marking { since_s, window_s } => self.step_marking(input, since_s, window_s),
            State::Replacing {
                target,
                since_s,
                frames,
            } => self.step_replacing(input, target, since_s, frames),
            State::Sliding { .. } => self.step_sliding(input),
            State::Stopping { frames, attempt } => self.step_stopping(input, frames, attempt),
            State::Searching { since_s, attempt } => self.step_searching(input, since_s, attempt),
            State::Returning {
                target,
                frames,
                attempt,
                from_s,
            } => self.step_returning(input, target, frames, attempt, from_s),
            State::Listening => self.step_listening(input),
            State::WeakStepping(step) => self.step_weak_stepping(input, step),
        }
        TrackerOutput {
            motion: self.motion(),
            event: self.events.pop(),
        }
    }
}

/// Deterministic noise for the tests: uniform over `span` (centred on zero), drawn from a
/// 64-bit linear congruential generator seeded with `seed`.
#[cfg(test)]
fn test_noise(seed: u64, span: f64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * span
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tracker(tilt: f64) -> Result<BeatSlide, InvalidParams> {
        let params = BeatSlideParams {
            tilt_deflection: tilt,
            ..BeatSlideParams::default()
        };
        BeatSlide::new(params, ArrayGeometry::default())
    }

    #[test]
    fn the_path_models_modes_are_checked() {
        let with = |turning_walk: f64, turn_onset: f64, turn_end: f64| {
            let params = BeatSlideParams {
                turning_walk,
                turn_onset,
                turn_end,
                ..BeatSlideParams::default()
            };
            BeatSlide::new(params, ArrayGeometry::default()).map(|_| ())
        };
        // One mode (the default), a turning mode, and a turning walk below the calm one
        // (an old config that raised `curvature_walk` alone: one mode).
        assert!(with(0.0, 0.05, 0.3).is_ok());
        assert!(with(150.0, 0.05, 0.3).is_ok());
        assert!(with(20.0, 0.05, 0.3).is_ok());
        for (walk, onset, end, names) in [
            (f64::NAN, 0.05, 0.3, "turning_walk"),
            (-1.0, 0.05, 0.3, "turning_walk"),
            (150.0, 0.0, 0.3, "turn_onset"),
            (150.0, 0.05, 0.6, "turn_end"),
            (150.0, f64::NAN, 0.3, "turn_onset"),
        ] {
            let e = with(walk, onset, end).expect_err("refused");
            assert!(e.0.contains(names), "{walk} {onset} {end}: {}", e.0);
        }
    }

    #[test]
    fn tilt_deflection_pushes_the_sensor_outward_from_below_the_pivot() {
        let t = tracker(0.027).unwrap();
        // 100 mm from the point below the pivot: 2.7 mm further out, along the radius.
        let s = t.sensor_from_belief(SurfacePoint::new(0.06, -0.08));
        assert!((s.x_m - 0.06 * 1.027).abs() < 1e-15, "{s:?}");
        assert!((s.z_m + 0.08 * 1.027).abs() < 1e-15, "{s:?}");
        // The moves are mapped back: commanding the belief puts the sensor on the target.
        let target = SurfacePoint::new(-0.11, 0.02);
        let back = t.sensor_from_belief(t.belief_from_sensor(target));
        assert!((back.x_m - target.x_m).abs() < 1e-15 && (back.z_m - target.z_m).abs() < 1e-15);
        // Below the pivot nothing moves; with no deflection nothing moves anywhere.
        let origin = t.sensor_from_belief(SurfacePoint::new(0.0, 0.0));
        assert_eq!((origin.x_m, origin.z_m), (0.0, 0.0));
        let rigid = tracker(0.0).unwrap();
        let p = SurfacePoint::new(0.05, 0.01);
        assert_eq!(rigid.sensor_from_belief(p), p);
    }

    /// A tracker seeded on an artery along x at z = 0 (points 5 mm apart, sliding +x).
    fn seeded() -> BeatSlide {
        let mut t = tracker(0.0).unwrap();
        let settings = filter_settings(&t.params);
        let seeds: Vec<Observation> = [0.0, 0.005]
            .iter()
            .map(|&x| Observation {
                point: SurfacePoint::new(x, 0.0),
                sd_m: 0.0003,
                lag_dir: [1.0, 0.0],
            })
            .collect();
        t.filter = Some(PathFilter::from_observations(&seeds, 0.0, settings).unwrap());
        t
    }

    /// A clear fix (SNR 10) with the artery `offset_m` off the array's centre, the sensor
    /// 15 mm along the path.
    fn fix(offset_m: f64) -> BeatFix {
        BeatFix {
            t_mid_s: 10.0,
            late_s: 0.0,
            kernel: KernelFit {
                offset_z_m: offset_m,
                element: 4.5 + offset_m / 0.002,
                offset_se_m: 0.0003,
                amplitude: 10.0,
                amplitude_se: 1.0,
                baseline: 0.0,
                width_m: 0.005,
                chi2: 6.0,
                at_edge: false,
            },
            sensor: SurfacePoint::new(0.015, 0.0),
            lag_dir: [1.0, 0.0],
            felt_offset: None,
            noise_sd_n: 0.01,
            aligned: timed_waveform(),
        }
    }

    /// A timed window's beat: the first harmonic alone.
    fn timed_waveform() -> Waveform {
        let mut w = Waveform::zeros();
        w[1] = 1.0;
        w
    }

    #[test]
    fn the_path_ahead_is_the_filters_course_with_its_growing_sd_and_only_while_tracking() {
        let mut t = seeded();
        let mut ahead = vec![PredictedPoint {
            point: SurfacePoint::new(1.0, 1.0),
            sd_m: None,
        }];
        t.path_ahead(&mut ahead);
        assert!(
            ahead.is_empty(),
            "seeding: no path ahead, and `out` is cleared"
        );
        t.state = t.sliding_from(SurfacePoint::new(0.005, 0.0)).unwrap();
        t.path_ahead(&mut ahead);
        assert_eq!(ahead.len(), PATH_AHEAD_POINTS);
        let filter = t.filter.unwrap();
        let (first, last) = (ahead[0], ahead[PATH_AHEAD_POINTS - 1]);
        assert!(
            first.point.distance_to(&filter.origin()) < 1e-12,
            "{first:?}"
        );
        // The seeds lie along +x: the course runs on along +x as far as the tracker goes blind.
        assert!((last.point.x_m - filter.origin().x_m - t.params.max_blind_m).abs() < 1e-4);
        assert!(last.point.z_m.abs() < 1e-4, "{last:?}");
        let sds: Vec<f64> = ahead.iter().map(|p| p.sd_m.unwrap()).collect();
        assert!(sds.windows(2).all(|w| w[1] > w[0]), "{sds:?}");
        assert!(
            (sds[PATH_AHEAD_POINTS - 1] - filter.predict(t.params.max_blind_m).sd_m).abs() < 1e-15
        );
        t.state = State::Finished(EndReason::Stopped);
        t.path_ahead(&mut ahead);
        assert!(ahead.is_empty());
    }

    #[test]
    fn an_untimed_fix_may_confirm_the_path_but_not_surprise_it() {
        let base = seeded();
        let nis = |offset_m: f64| {
            let mut f = base.filter.unwrap();
            let o = Observation {
                point: fix(offset_m).point(),
                sd_m: base.fix_sd(&fix(offset_m).kernel),
                lag_dir: [1.0, 0.0],
            };
            f.update(&o).ok().map(|s| s.nis())
        };
        // An offset the gate passes but the model finds surprising (NIS between 4 and the
        // gate's 16), and one it expects.
        let surprising = (1..200)
            .map(|i| i as f64 * 5e-5)
            .find(|&d| nis(d).is_some_and(|n| n > 2.0 * SURPRISE_NIS))
            .expect("some offset inside the gate surprises the model");
        assert!(nis(surprising).is_some_and(|n| n < 16.0));
        let expected = surprising / 4.0;
        assert!(nis(expected).is_some_and(|n| n < SURPRISE_NIS));
        // Timed, the surprising fix is taken (the path turned); untimed it is refused and
        // the path model is left as it was.
        let mut timed = base.clone();
        assert!(timed.accept(&fix(surprising), false).is_ok());
        let mut untimed = base.clone();
        let why = untimed.accept(&fix(surprising), true);
        assert!(
            matches!(why, Err(Miss::UntimedSurprise { nis }) if nis > SURPRISE_NIS),
            "{why:?}"
        );
        assert_eq!(untimed.filter, base.filter);
        // An untimed fix on the predicted path is taken.
        let mut confirming = base.clone();
        assert!(confirming.accept(&fix(expected), true).is_ok());
        assert_ne!(confirming.filter, base.filter);
    }

    /// `seeded()` with a pulse whose usual amplitude is `usual_n`, one beat per fix.
    #[test]
    fn moving_tissue_softens_the_fixes_and_withholds_windows_of_several_beats() {
        let base = seeded();
        let mut moving = base.clone();
        for k in 0..9 {
            let innovation = if k % 2 == 0 { 0.002 } else { -0.002 };
            moving.tissue.push(innovation, 1e-6);
        }
        assert!(moving.tissue.sd_m() > 0.0015);
        // The same fix off the predicted path: the still model moves its course most of
        // the way to it, the moving one less.
        let off = 0.0015;
        let mut still = base.clone();
        assert!(still.accept(&fix(off), false).is_ok());
        assert!(moving.accept(&fix(off), false).is_ok());
        let (still_z, moving_z) = (
            still.filter.expect("model").origin().z_m,
            moving.filter.expect("model").origin().z_m,
        );
        assert!(
            still_z > 1.5 * moving_z && moving_z > 0.0,
            "still {still_z}, moving {moving_z}"
        );
        // A window of one beat is reported either way; one of several only while the
        // tissue stays still.
        assert!(!base.smeared(4.0) && !base.smeared(1.0));
        assert!(moving.smeared(4.0) && !moving.smeared(1.0));
    }

    fn with_pulse(usual_n: f64) -> BeatSlide {
        let mut t = seeded();
        let mut template = Waveform::zeros();
        template[1] = 1.0;
        let template_pp = peak_to_peak(&template);
        t.pulse = Some(Pulse {
            clock: BeatClock::new(
                crate::signal::harmonic::PulsePhase {
                    t_ref_s: 0.0,
                    period_s: 1.0,
                },
                BeatClockSettings::default(),
            ),
            template,
            template_pp,
            snr_per_beat: 10.0,
            late_rms_s: 0.05,
            amplitude_n: usual_n,
            reported_period_s: 1.0,
        });
        t.beats_per_fix = 1;
        t
    }

    #[test]
    fn a_faint_pulse_is_never_reported_however_clear_or_well_placed() {
        let base = with_pulse(0.08);
        let pp = base.pulse.map(|p| p.template_pp).unwrap();
        // The far tail of an artery beyond the array's reach: a tenth of the usual amplitude,
        // but measured so well (SNR 10) and so near the predicted path that only its
        // amplitude gives it away.
        let mut faint = fix(0.0);
        faint.kernel.amplitude = 0.008 / pp;
        faint.kernel.amplitude_se = faint.kernel.amplitude / 10.0;
        let mut t = base.clone();
        let why = t.accept(&faint, false);
        assert!(
            matches!(why, Err(Miss::Faint { amplitude_n, usual_n })
                if (amplitude_n - 0.008).abs() < 1e-12 && usual_n == 0.08),
            "{why:?}"
        );
        assert_eq!(
            t.filter, base.filter,
            "a refused fix leaves the path model alone"
        );
        // At the edge of the gate: just above the fraction is taken, just below refused.
        for (fraction, taken) in [
            (FAINT_FRACTION * 1.01, true),
            (FAINT_FRACTION * 0.99, false),
        ] {
            let mut f = fix(0.0);
            f.kernel.amplitude = fraction * 0.08 / pp;
            f.kernel.amplitude_se = f.kernel.amplitude / 10.0;
            let mut t = base.clone();
            assert_eq!(t.accept(&f, false).is_ok(), taken, "{fraction}");
        }
        // The same check guards the searches at rest.
        let mut weak = fix(0.0).kernel;
        weak.amplitude = 0.1 * 0.08 / pp;
        assert!(matches!(
            base.check_amplitude(&weak),
            Err(Miss::Faint { .. })
        ));
        // Before any pulse is known (the first mark) there is nothing to compare with.
        assert!(seeded().check_amplitude(&weak).is_ok());
    }

    /// `seeded()` with `frames` frames of sliding along +x at 10 mm/s pushed, the lag's
    /// direction `u` in each and the load putting the sensor `felt` from the belief
    /// (`None`: no reading).
    fn sliding_with_load(frames: usize, u: [f64; 2], felt: Option<[f64; 2]>) -> BeatSlide {
        let mut t = seeded();
        push_sliding(&mut t, 0..frames, u, felt);
        t
    }

    /// Frames `range` of that slide (frame `i` at 10 s + 10 ms·i) pushed onto `t`.
    fn push_sliding(
        t: &mut BeatSlide,
        range: std::ops::Range<usize>,
        u: [f64; 2],
        felt: Option<[f64; 2]>,
    ) {
        for i in range {
            let t_s = 10.0 + 0.01 * i as f64;
            let sensor = SurfacePoint::new(0.005 + 0.0001 * i as f64, 0.0);
            let loaded = felt.map(|f| SurfacePoint::new(sensor.x_m + f[0], sensor.z_m + f[1]));
            let frame = crate::types::TactileFrame {
                t_s,
                seq: i as u64,
                force_n: [0.0; crate::types::ELEMENTS],
            };
            t.history.push(frame, sensor, u, loaded);
        }
    }

    #[test]
    fn the_load_reads_a_heavy_rigs_lag_while_sliding() {
        // A rig whose sensor trails 9 mm (the heavy instrument's 8-11) against the prior's
        // 4.5: one window read by the load moves the lag most of the way.
        let prior = seeded().filter.expect("seeded").lag_m();
        let mut t = sliding_with_load(100, [1.0, 0.0], Some([-0.009, 0.0003]));
        t.read_deflection_from_load(10.0);
        let lag = t.filter.expect("seeded").lag_m();
        assert!((prior - 0.0045).abs() < 1e-9, "{prior}");
        assert!(lag > 0.0075 && lag < 0.009, "{lag}");
        // Across the motion the reading is the rod's deflection the models do not hold:
        // the first window's taken whole, later ones averaged in at FELT_ACROSS_WEIGHT.
        let across = t.felt_across.expect("read");
        assert!(
            across[0].abs() < 1e-12 && (across[1] - 0.0003).abs() < 1e-12,
            "{across:?}"
        );
        push_sliding(&mut t, 100..200, [1.0, 0.0], Some([-0.009, 0.0013]));
        t.read_deflection_from_load(11.0);
        let across = t.felt_across.expect("read");
        let expected = 0.0003 + FELT_ACROSS_WEIGHT * (0.0013 - 0.0003);
        assert!((across[1] - expected).abs() < 1e-12, "{across:?}");
        // The part of the offset across the lag's direction is no lag.
        assert_eq!(
            sliding::lag_read_by_load([-0.009, 0.004], [1.0, 0.0]),
            Some(0.009)
        );
        assert_eq!(
            sliding::felt_across_motion([-0.009, 0.004], [1.0, 0.0]),
            Some([0.0, 0.004])
        );
        assert_eq!(
            sliding::felt_across_motion([-0.009, 0.0], [0.85, 0.0]),
            None
        );
        assert_eq!(
            sliding::lag_read_by_load([0.0, -0.006], [0.0, 0.95]),
            Some(0.006 / 0.95)
        );
        // While the direction swings round (its mean shorter than 0.9), no reading: nor
        // for a window with a frame unread, nor with the load's reading turned off.
        assert_eq!(sliding::lag_read_by_load([-0.009, 0.0], [0.85, 0.0]), None);
        assert_eq!(sliding::lag_read_by_load([-0.009, 0.0], [0.0, 0.0]), None);
        let mut swinging = sliding_with_load(100, [0.6, 0.6], Some([-0.009, 0.0]));
        swinging.read_deflection_from_load(10.0);
        let mut unread = sliding_with_load(100, [1.0, 0.0], None);
        unread.read_deflection_from_load(10.0);
        let mut off = sliding_with_load(100, [1.0, 0.0], Some([-0.009, 0.0]));
        off.params.load_gate_m = 0.0;
        off.read_deflection_from_load(10.0);
        for t in [swinging, unread, off] {
            assert_eq!(t.felt_across, None);
            assert_eq!(t.filter.expect("seeded").lag_m(), prior);
        }
    }

    /// A sliding fix is placed where the load's smoothed offset across the motion moves it:
    /// the same fix, 1 mm further along +z.
    #[test]
    fn a_sliding_fix_is_moved_by_the_loads_offset_across_the_motion() {
        let place = |across: Option<[f64; 2]>| {
            let mut t = with_pulse(0.08);
            t.felt_across = across;
            t.accept(&fix(0.0), false).expect("a clear fix on the path")
        };
        let (plain, moved) = (place(None), place(Some([0.0, 0.001])));
        assert!(
            (moved.z_m - plain.z_m - 0.001).abs() < 1e-9,
            "{plain:?} {moved:?}"
        );
        assert!((moved.x_m - plain.x_m).abs() < 1e-9);
    }

    /// The default gate on `seeded()` (heading +x): the load's place for a point is the
    /// believed one moved by the window's felt offset, and only its part across the path
    /// counts.
    #[test]
    fn the_load_disputes_a_point_only_across_the_path_and_beyond_the_gate() {
        let t = seeded();
        let gate = t.params.load_gate_m;
        let raw = SurfacePoint::new(0.015, 0.0004);
        let point = SurfacePoint::new(0.0105, 0.0004);
        // Along the path, however far (the lag's direction): no dispute.
        assert_eq!(t.load_disagrees(raw, point, Some([-0.0045, 0.0])), None);
        // Across it, just inside and just beyond the gate.
        assert_eq!(
            t.load_disagrees(raw, point, Some([-0.0045, 0.99 * gate])),
            None
        );
        let loaded = t
            .load_disagrees(raw, point, Some([-0.0045, 1.01 * gate]))
            .expect("disputed");
        assert!((loaded.x_m - 0.0105).abs() < 1e-15);
        assert!((loaded.z_m - (0.0004 + 1.01 * gate)).abs() < 1e-15);
        // No reading, or the gate off: nothing to dispute.
        assert_eq!(t.load_disagrees(raw, point, None), None);
        let mut off = seeded();
        off.params.load_gate_m = 0.0;
        assert_eq!(off.load_disagrees(raw, point, Some([0.0, 0.01])), None);
        // Before a path model (the first seed), the whole distance counts.
        let mut first = seeded();
        first.filter = None;
        assert!(
            first
                .load_disagrees(raw, raw, Some([1.01 * gate, 0.0]))
                .is_some()
        );
    }

    /// `accepted` taken on the path, then `after` (the same fix, or one changed after the
    /// gate) handed on: the points reported, and where the track then is.
    fn reported_after(
        t: BeatSlide,
        accepted: &BeatFix,
        after: &BeatFix,
    ) -> (usize, Option<SurfacePoint>) {
        let (located, t) = handed_on(t, accepted, after, false);
        (located, t.last_fix)
    }

    /// As [`reported_after`], `spans_miss` as the slide's window says: the points reported,
    /// and the tracker after.
    fn handed_on(
        mut t: BeatSlide,
        accepted: &BeatFix,
        after: &BeatFix,
        spans_miss: bool,
    ) -> (usize, BeatSlide) {
        let point = t.accept(accepted, false).expect("a clear fix on the path");
        t.after_fix(after, point, accepted.sensor, 10.0, spans_miss, false);
        // Reported, or held for the next window (`hold`).
        let located = std::iter::from_fn(|| t.events.pop())
            .filter(|e| matches!(e, TrackerEvent::Located(_)))
            .count()
            + usize::from(t.held.is_some());
        (located, t)
    }

    /// The points reported so far, emptying the queue.
    fn located_points(t: &mut BeatSlide) -> Vec<LocatedPoint> {
        std::iter::from_fn(|| t.events.pop())
            .filter_map(|e| match e {
                TrackerEvent::Located(p) => Some(p),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn a_sliding_point_is_reported_once_the_next_window_finds_the_artery() {
        let first = fix(0.0);
        let mut second = fix(0.0001);
        second.t_mid_s = 11.0;
        let slide = |t: &mut BeatSlide, f: &BeatFix, t_s: f64| {
            let point = t.accept(f, false).expect("a clear fix on the path");
            t.after_fix(f, point, f.sensor, t_s, false, false);
        };
        // A fix is held, not reported, until the next window has been analysed.
        let mut t = with_pulse(0.08);
        slide(&mut t, &first, 10.5);
        assert!(located_points(&mut t).is_empty());
        assert!(t.held.is_some());
        // The next window's fix confirms it: the first point is reported, at its own time.
        slide(&mut t, &second, 11.5);
        let reported = located_points(&mut t);
        assert_eq!(reported.len(), 1);
        assert_eq!(reported[0].t_s, first.t_mid_s);
        // A missed window drops the held point: it is never reported, even once the
        // artery is found again.
        t.window_missed(Miss::Blind);
        slide(&mut t, &first, 12.5);
        assert!(located_points(&mut t).is_empty());
        // Lost: the held point goes with the track.
        t.finish(EndReason::Lost, 13.0);
        assert!(located_points(&mut t).is_empty());
        // An end that is not a loss reports it, before the end.
        for reason in [EndReason::LengthReached, EndReason::Stopped] {
            let mut t = with_pulse(0.08);
            slide(&mut t, &first, 10.5);
            t.finish(reason, 11.0);
            let events: Vec<TrackerEvent> = std::iter::from_fn(|| t.events.pop()).collect();
            assert!(
                matches!(
                    events.as_slice(),
                    [.., TrackerEvent::Located(_), TrackerEvent::Finished { .. }]
                ),
                "{reason:?}: {events:?}"
            );
        }
    }

    /// A clear fix taken on the path, then the same fix with its kernel fit changed by
    /// `change` handed on.
    fn reported_with_kernel(change: impl Fn(&mut KernelFit)) -> (usize, Option<SurfacePoint>) {
        let f = fix(0.0);
        let mut changed = f;
        change(&mut changed.kernel);
        reported_after(with_pulse(0.08), &f, &changed)
    }

    /// A clear fix taken on the path, then the same fix centred on `element` handed on.
    /// The artery held still on the array since the last fix (no sweep).
    fn reported_at(t: BeatSlide, element: f64) -> (usize, Option<SurfacePoint>) {
        reported_swept(t, element, element)
    }

    /// A clear fix taken on the path, then the same fix centred on `element` handed on, the
    /// last fix's centre having been `previous_element`.
    fn reported_swept(
        mut t: BeatSlide,
        previous_element: f64,
        element: f64,
    ) -> (usize, Option<SurfacePoint>) {
        let f = fix(0.0);
        let mut at = f;
        at.kernel.element = element;
        t.spatial.element = previous_element;
        reported_after(t, &f, &at)
    }

    /// While sliding, a fix whose place the load disputes steers the track (the path
    /// grows, the last fix moves) but is not reported; an undisputed one is reported.
    #[test]
    fn a_sliding_fix_the_load_disputes_steers_but_is_not_reported() {
        let run = |felt: Option<[f64; 2]>| {
            let mut f = fix(0.0);
            f.felt_offset = felt;
            reported_after(with_pulse(0.08), &f, &f)
        };
        let gate = BeatSlideParams::default().load_gate_m;
        let (reported, last) = run(Some([-0.004, 0.3 * gate]));
        assert_eq!(reported, 1);
        let (disputed, last_disputed) = run(Some([-0.004, 2.0 * gate]));
        assert_eq!(disputed, 0, "a disputed point is not reported");
        assert_eq!(last_disputed, last, "but it steers the track as before");
        assert!(last.is_some());
        let (unread, _) = run(None);
        assert_eq!(unread, 1, "without a reading nothing changes");
    }

    #[test]
    fn after_a_weak_window_an_irregular_heart_spans_it_and_a_regular_one_starts_afresh() {
        // `with_pulse`: a 1 s period; lateness RMS at a tenth of it, then at a fiftieth.
        let mut irregular = with_pulse(0.08);
        if let Some(p) = &mut irregular.pulse {
            p.late_rms_s = 0.1;
        }
        let mut regular = irregular.clone();
        if let Some(p) = &mut regular.pulse {
            p.late_rms_s = 0.02;
        }
        assert_eq!(
            irregular.window_after_miss(3.0, 4.0, true),
            (3.0, 2.0, true)
        );
        assert_eq!(regular.window_after_miss(3.0, 4.0, true), (4.0, 1.0, false));
        // A window refused for anything but weakness (its place, its timing) is not spanned.
        assert_eq!(
            irregular.window_after_miss(3.0, 4.0, false),
            (4.0, 1.0, false)
        );
        let mut unknown = irregular.clone();
        unknown.pulse = None;
        assert!(!unknown.window_after_miss(3.0, 4.0, true).2);
    }

    #[test]
    fn a_fix_spanning_a_missed_window_steers_but_is_not_reported() {
        let run = |spans_miss: bool| {
            let f = fix(0.0);
            let (located, t) = handed_on(with_pulse(0.08), &f, &f, spans_miss);
            (located, t.last_fix, t.pulse.map(|p| p.snr_per_beat))
        };
        let (reported, last, snr) = run(false);
        let (spanned, last_spanned, snr_spanned) = run(true);
        assert_eq!(
            (reported, spanned),
            (1, 0),
            "a spanning fix is not reported"
        );
        assert_eq!(last_spanned, last, "but it steers the track as before");
        // Its SNR came from two windows' beats: per beat it counts for less.
        assert!(snr_spanned < snr, "{snr_spanned:?} vs {snr:?}");
    }

    /// Sliding across a bend the artery sweeps across the array within a window: a centre
    /// within half that sweep of the outer element may have been beyond it for part of the
    /// window. The same place is reported when the artery held still on the array.
    #[test]
    fn a_fix_that_swept_to_the_arrays_end_steers_but_is_not_reported() {
        let run = |previous_element: f64| reported_swept(with_pulse(0.08), previous_element, 0.6);
        let (held, last) = run(0.8);
        let (swept, last_swept) = run(2.0);
        assert_eq!(
            (held, swept),
            (1, 0),
            "1.4 elements of sweep: 0.7 of margin"
        );
        assert_eq!(last_swept, last, "it steers the track as before");
        // The other end alike, and a sweep that stays clear of the end is reported.
        assert_eq!(reported_swept(with_pulse(0.08), 7.0, 8.4).0, 0);
        assert_eq!(reported_swept(with_pulse(0.08), 8.0, 8.4).0, 1);
        assert_eq!(reported_swept(with_pulse(0.08), 2.6, 4.5).0, 1);
    }

    /// A fix whose artery lay more than two elements from the last fix's place crossed the
    /// array within its window, wherever it ends up: it steers, it is not reported.
    #[test]
    fn a_fix_that_swept_across_the_array_steers_but_is_not_reported() {
        let run = |previous_element: f64| reported_swept(with_pulse(0.08), previous_element, 4.5);
        let (held, last) = run(4.5);
        assert_eq!(held, 1);
        assert_eq!(run(2.6).0, 1, "1.9 elements");
        assert_eq!(run(6.4).0, 1, "the other way");
        let (swept, last_swept) = run(2.4);
        assert_eq!(swept, 0, "2.1 elements");
        assert_eq!(run(6.6).0, 0, "the other way");
        assert_eq!(last_swept, last, "it steers the track as before");
    }

    #[test]
    fn a_regular_hearts_untimed_sliding_fix_steers_but_is_not_reported() {
        let timed = fix(0.0);
        let mut untimed = timed;
        untimed.aligned = Waveform::zeros();
        assert!(timed.is_timed() && !untimed.is_timed());
        // `with_pulse`'s period is 1 s; lateness RMS at a fiftieth of it, then a tenth.
        let with_lateness = |late_rms_s: f64| {
            let mut t = with_pulse(0.08);
            if let Some(p) = &mut t.pulse {
                p.late_rms_s = late_rms_s;
            }
            t
        };
        let (reported, last) = reported_after(with_lateness(0.02), &timed, &timed);
        let (reported_untimed, last_untimed) =
            reported_after(with_lateness(0.02), &timed, &untimed);
        assert_eq!((reported, reported_untimed), (1, 0));
        assert_eq!(
            last_untimed, last,
            "it steers the track as a timed one does"
        );
        // An irregular heart's is reported: its beats explain a window the clock missed.
        assert_eq!(reported_after(with_lateness(0.1), &timed, &untimed).0, 1);
    }

    #[test]
    fn a_sliding_fix_beyond_the_arrays_outer_elements_steers_but_is_not_reported() {
        let run = |element: f64| reported_at(with_pulse(0.08), element);
        // Both outer elements' centres are still under the array; a hair beyond is not.
        assert_eq!(run(0.0).0, 1);
        assert_eq!(run(9.0).0, 1);
        let (below, last_below) = run(-0.01);
        let (above, last_above) = run(9.01);
        assert_eq!(
            (below, above),
            (0, 0),
            "an extrapolated place is not reported"
        );
        assert_eq!(last_below, run(4.5).1, "but it steers the track as before");
        assert_eq!(last_above, run(4.5).1);
        assert_eq!(run(f64::NAN).0, 0);
    }

    #[test]
    fn a_sliding_fix_whose_fit_cannot_vouch_for_2_mm_steers_but_is_not_reported() {
        let run = |se_m: f64| reported_with_kernel(|k| k.offset_se_m = se_m);
        // 3 SE within 2 mm: an SE of 2/3 mm is the edge.
        let (vouched, last) = run(0.0006);
        assert_eq!(vouched, 1);
        let (loose, last_loose) = run(0.0007);
        assert_eq!(loose, 0, "a place its fit cannot vouch for is not reported");
        assert_eq!(last_loose, last, "but it steers the track as before");
        assert_eq!(run(f64::NAN).0, 0);
        assert_eq!(run(f64::INFINITY).0, 0);
    }

    #[test]
    fn a_sliding_fix_no_one_kernel_fits_steers_but_is_not_reported() {
        let run = |chi2: f64| reported_with_kernel(|k| k.chi2 = chi2);
        // Ten trusted elements, four parameters: 22.46 is chi-square(6)'s 99.9 % point.
        let (fits, last) = run(21.5);
        assert_eq!(fits, 1);
        let (smeared, last_smeared) = run(23.5);
        assert_eq!(smeared, 0, "a smear no one kernel fits is not reported");
        assert_eq!(last_smeared, last, "but it steers the track as before");
        assert_eq!(run(f64::NAN).0, 0);
    }

    #[test]
    fn under_moving_tissue_a_fix_near_the_arrays_end_is_not_reported() {
        let run = |element: f64, motion_m: f64| {
            let mut t = with_pulse(0.08);
            for k in 0..9 {
                t.tissue
                    .push(if k % 2 == 0 { motion_m } else { -motion_m }, 0.0);
            }
            reported_at(t, element).0
        };
        // Still tissue: up to the outer elements' centres.
        assert_eq!(run(0.2, 0.0), 1);
        assert_eq!(run(8.8, 0.0), 1);
        // Moving 1 mm (SD), half a pitch: the centre must lie half an element inside.
        assert_eq!(run(0.45, 0.001), 0);
        assert_eq!(run(8.55, 0.001), 0);
        assert_eq!(run(0.55, 0.001), 1);
        assert_eq!(run(8.45, 0.001), 1);
    }

    #[test]
    fn a_sliding_fix_well_below_the_usual_amplitude_steers_but_is_not_reported() {
        let run = |usual_n: f64| reported_after(with_pulse(usual_n), &fix(0.0), &fix(0.0));
        let felt = with_pulse(1.0).amplitude_n(&fix(0.0).kernel);
        let (at_usual, last) = run(felt);
        assert_eq!(at_usual, 1);
        assert_eq!(run(felt / REPORT_FRACTION * 0.99).0, 1);
        let (weak, last_weak) = run(felt / REPORT_FRACTION * 1.01);
        assert_eq!(
            weak, 0,
            "a fix below the share of the usual amplitude is not reported"
        );
        assert_eq!(last_weak, last, "but it steers the track as before");
        // A pulse fading fix by fix (the last fix 10 % above this one) stays reported,
        // however far below the usual; a dip below the last fix is not.
        let after = |previous_n: f64| {
            let mut t = with_pulse(2.0 * felt);
            t.previous_amplitude_n = previous_n;
            reported_after(t, &fix(0.0), &fix(0.0)).0
        };
        assert_eq!(after(1.1 * felt), 1);
        assert_eq!(after(1.5 * felt), 0);
    }

    #[test]
    fn near_the_arrays_end_a_weaker_pulse_is_a_flank_and_not_reported() {
        let felt = with_pulse(1.0).amplitude_n(&fix(0.0).kernel);
        // Usual amplitude `usual_n`, the last fix as strong as this one (no fade to excuse
        // nor to blame), the fix centred on `element`.
        let run = |element: f64, usual_n: f64| {
            let mut t = with_pulse(usual_n);
            t.previous_amplitude_n = felt;
            reported_at(t, element).0
        };
        let below_flank = felt / FLANK_FRACTION * 1.01;
        let above_flank = felt / FLANK_FRACTION * 0.99;
        // Inside, 0.79 of the usual is reported (above `REPORT_FRACTION`).
        assert_eq!(run(4.5, below_flank), 1);
        assert_eq!(run(1.01, below_flank), 1);
        assert_eq!(run(7.99, below_flank), 1);
        // Within a pitch of either end it is a flank; at 0.81 it is the artery.
        assert_eq!(run(0.99, below_flank), 0);
        assert_eq!(run(8.01, below_flank), 0);
        assert_eq!(run(0.2, above_flank), 1);
        assert_eq!(run(8.8, above_flank), 1);
        // A pulse fading fix by fix is excused inside, not within a pitch of an end.
        let fading = |element: f64| {
            let mut t = with_pulse(2.0 * felt);
            t.previous_amplitude_n = 1.1 * felt;
            reported_at(t, element).0
        };
        assert_eq!(fading(4.5), 1);
        assert_eq!(fading(0.5), 0);
    }

    #[test]
    fn a_load_gate_beyond_the_arrays_reach_is_refused() {
        for bad in [-0.001, 0.011, f64::NAN] {
            let params = BeatSlideParams {
                load_gate_m: bad,
                ..BeatSlideParams::default()
            };
            let e = BeatSlide::new(params, ArrayGeometry::default())
                .err()
                .map(|e| e.0)
                .unwrap_or_default();
            assert!(e.contains("load_gate_m"), "{bad}: {e}");
        }
    }

    #[test]
    fn bad_tilt_deflection_is_refused() {
        for bad in [-0.01, 0.5, f64::NAN, f64::INFINITY] {
            let e = tracker(bad).err().map(|e| e.0).unwrap_or_default();
            assert!(e.contains("tilt_deflection"), "{bad}: {e}");
        }
    }

    /// On the way back to the last fix after a loss: `with_pulse` (a clear, regular pulse,
    /// one beat per fix), the last fix at the second seed point, going back along -x.
    fn going_back(usual_n: f64) -> BeatSlide {
        let mut t = with_pulse(usual_n);
        if let Some(p) = &mut t.pulse {
            p.late_rms_s = 0.01;
        }
        let last = SurfacePoint::new(0.005, 0.0);
        t.last_fix = Some(last);
        t.state = State::Returning {
            target: last,
            frames: 3,
            attempt: 2,
            from_s: Some(9.0),
        };
        t
    }

    /// A clear fix heard going back, 8 mm to the side of the straight path 7 mm past the
    /// last fix (a bend the slide outran); no lag (the window where the return began).
    fn heard_going_back() -> BeatFix {
        let mut f = fix(0.008);
        f.kernel.amplitude = 12.0;
        f.sensor = SurfacePoint::new(0.012, 0.0);
        f.lag_dir = [0.0, 0.0];
        f
    }

    #[test]
    fn a_clear_fix_heard_going_back_turns_the_path_and_the_slide_goes_on_unreported() {
        let mut t = going_back(0.08);
        let heard = heard_going_back();
        let point = t.judge_returning(&heard).expect("a clear fix on the array");
        assert!(
            point.distance_to(&SurfacePoint::new(0.012, 0.008)) < 1e-3,
            "{point:?}"
        );
        t.refound_returning(&heard, point, heard.sensor, 10.0);
        let located = std::iter::from_fn(|| t.events.pop())
            .filter(|e| matches!(e, TrackerEvent::Located(_)))
            .count();
        assert_eq!(located, 0, "a freely timed fix steers, it is not reported");
        assert!(matches!(t.state, State::Sliding { .. }), "{:?}", t.state);
        assert_eq!(t.last_fix, Some(point));
        // The path model now runs through the fix, turned toward it.
        let f = t.filter.expect("a path model");
        let (s, _) = f.to_local(point);
        let there = f.predict(s);
        assert!(
            there.point.distance_to(&point) < 1e-3,
            "{there:?} {point:?}"
        );
        assert!(there.heading_rad > 0.3, "heading {}", there.heading_rad);
        // The slide goes on ahead of the fix, not back toward the last one.
        let State::Sliding { target, .. } = t.state else {
            unreachable!()
        };
        assert!(f.to_local(target).0 > s, "target {target:?}");
    }

    #[test]
    fn going_back_a_weak_faint_or_edge_fix_is_refused_and_nothing_changes() {
        let refused = |what: &str, usual_n: f64, change: fn(&mut BeatFix)| {
            let mut t = going_back(usual_n);
            let mut heard = heard_going_back();
            change(&mut heard);
            let filter = t.filter;
            assert!(t.judge_returning(&heard).is_err(), "{what}");
            assert_eq!(t.filter, filter, "{what}: the path model is unchanged");
            assert_eq!(t.last_fix, Some(SurfacePoint::new(0.005, 0.0)), "{what}");
        };
        refused("weak", 0.08, |f| f.kernel.amplitude = 9.0);
        refused("at the edge", 0.08, |f| f.kernel.at_edge = true);
        refused("beyond the array", 0.08, |f| f.kernel.element = 9.7);
        refused("loosely placed", 0.08, |f| f.kernel.offset_se_m = 0.005);
        refused("faint", 1e3, |_| {});
    }

    #[test]
    fn heard_going_back_once_too_often_the_track_ends_lost() {
        let mut t = going_back(0.08);
        t.returns = t.params.max_returns;
        let heard = heard_going_back();
        let point = t.judge_returning(&heard).expect("a clear fix on the array");
        t.refound_returning(&heard, point, heard.sensor, 10.0);
        assert_eq!(t.state, State::Finished(EndReason::Lost));
    }

    /// A regular heart's clear pulse goes back listening at once; an irregular heart's, a
    /// weak pulse's (several beats per fix), or with `listen_returning` off, it searches
    /// where it stopped first.
    #[test]
    fn only_a_regular_hearts_clear_pulse_goes_back_without_searching_where_it_stopped() {
        let after_stop = |change: &dyn Fn(&mut BeatSlide)| {
            let mut t = going_back(0.08);
            t.state = State::Stopping {
                frames: 5,
                attempt: 1,
            };
            change(&mut t);
            let frame = crate::types::TactileFrame {
                t_s: 20.0,
                seq: 1,
                force_n: [0.0; crate::types::ELEMENTS],
            };
            let input = TrackerInput {
                frame: &frame,
                sensor: SurfacePoint::new(0.03, 0.0),
                settled: true,
                loaded_sensor: None,
            };
            t.step_stopping(&input, 5, 1);
            t.state
        };
        assert!(matches!(
            after_stop(&|_| {}),
            State::Returning { attempt: 2, .. }
        ));
        let searches = [
            after_stop(&|t| {
                if let Some(p) = &mut t.pulse {
                    p.late_rms_s = 0.2;
                }
            }),
            after_stop(&|t| t.beats_per_fix = 3),
            after_stop(&|t| t.params.listen_returning = false),
        ];
        for state in searches {
            assert!(
                matches!(state, State::Searching { attempt: 1, .. }),
                "{state:?}"
            );
        }
    }
}
