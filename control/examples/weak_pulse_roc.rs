//! The weak-pulse detector's receiver operating characteristic against the detection bound
//! (issue 18): detection rate against false-alarm rate at three pulse strengths, each
//! chosen by the bound (the position-searched ideal detector deciding in 5, 15 and 40
//! beats at pfa 0.05, pd 0.9, for the same kernel, noise and waveform), and the beats the
//! detector takes to decide against the bound's.
//!
//! Run: `cargo run --release -p pulsetrack-control --example weak_pulse_roc [-- TRIALS [SEED [DRAWS]]]`
//! (default 200 trials per strength and of noise only, seed 18, 1000 noise-law draws).
//! docs/BENCHMARKS.md ("The weak pulse: ROC against the bound") records the output.
//!
//! Random numbers: the crate's test generator (`control/src/test_normals.rs`, SplitMix64 and
//! Box-Muller) included by path, the same algorithm as the detector's tests: the library has
//! no random numbers of its own and a crate for this would be a new dependency.
//!
//! How a trial is drawn (as `weak_pulse/detector_tests.rs` draws its frames): a heart rate
//! uniform over 0.7-2.3 Hz (inside the searched 0.6-2.5 Hz with room for its wander), beat
//! intervals varying by about 4.6 % (breathing, a slow wander, beat-to-beat scatter), the
//! generic pressure waveform, the kernel family (`element_kernel`, 5 mm wide) with the
//! artery anywhere under the elements (±9 mm), Gaussian element noise of 12 mN at 100 Hz.
//! The pulse's amplitude is set per trial so that the bound, at that trial's mean period
//! and position, needs exactly the strength's beats.
//!
//! What is recorded: the detector's log likelihood ratio at every segment end (its
//! `Progress`), as a running maximum. A window of `k` segments alarms at threshold `T` when
//! that maximum by segment `k` exceeds `T`; thresholds come from the detector's own noise
//! law (`NoiseLaw`, measured on separate draws) at nominal false-alarm rates, and the
//! false-alarm rates are then measured on independent noise-only trials of the same
//! windows. Each detector is built with the highest of those thresholds, so it runs on
//! until every lower one is crossed or its limit comes: one run serves every threshold.

extern crate pulsetrack_control as control;

#[path = "../src/test_heart.rs"]
mod test_heart;
#[path = "../src/test_normals.rs"]
mod test_normals;

use control::signal::detection_bound::{
    glrt_threshold, normal_quantile, per_beat, snr_needed, waveform_energy,
};
use control::signal::kernel_fit::element_kernel;
use control::signal::weak_pulse::{
    NoiseLaw, PulseShape, WeakPulseDetector, WeakPulseSettings, generic_pressure,
};
use control::types::{ELEMENTS, TactileFrame};
use test_heart::{BeatCursor, beats};
use test_normals::Normals;

const SIGMA_N: f64 = 0.012;
const FS_HZ: f64 = 100.0;
const PITCH_M: f64 = 0.002;
const WIDTH_M: f64 = 0.005;
/// What the bound is asked: the strengths are the beats it needs at this pfa and pd.
const BOUND_PFA: f64 = 0.05;
const BOUND_PD: f64 = 0.9;
const STRENGTHS_BEATS: [f64; 3] = [5.0, 15.0, 40.0];
/// The window: twice the bound's beats (the goal), and the detector's limit.
const WINDOW_X_BOUND: f64 = 2.0;
const LIMIT_S: f64 = 120.0;
const RATES_HZ: (f64, f64) = (0.7, 2.3);
const REACH_M: f64 = 0.009;
/// Nominal false-alarm rates of the ROC's thresholds; the designed one.
const PFAS: [f64; 5] = [0.01, 0.02, 0.05, 0.1, 0.2];
const DESIGNED_PFA: f64 = 0.05;

fn main() {
    let mut args = std::env::args().skip(1);
    let mut number = |name: &str, default: u64| -> u64 {
        match args.next() {
            None => default,
            Some(s) => s.parse().unwrap_or_else(|_| {
                eprintln!("weak_pulse_roc: {name} must be a whole number, got {s:?}");
                std::process::exit(2)
            }),
        }
    };
    let trials = number("TRIALS", 200) as usize;
    let seed = number("SEED", 18);
    let draws = number("DRAWS", 1000) as usize;
    if trials == 0 || (draws as f64) * PFAS[0] < 10.0 {
        eprintln!(
            "weak_pulse_roc: TRIALS must be at least 1 and DRAWS at least {:.0}",
            10.0 / PFAS[0]
        );
        std::process::exit(2);
    }
    let settings = WeakPulseSettings {
        limit_s: LIMIT_S,
        ..WeakPulseSettings::default()
    };
    let segment_s = settings.segment_s;
    let looks = (LIMIT_S / segment_s).round() as usize;

    // The detector's thresholds, from its noise law on separate draws.
    let started = std::time::Instant::now();
    let mut rng = Normals::new(seed);
    let law = NoiseLaw::measure(&settings, &PulseShape::Generic, draws, &mut || rng.next())
        .unwrap_or_else(|e| fail(&e.to_string()));
    let thresholds: Vec<Vec<f64>> = PFAS
        .iter()
        .map(|&p| {
            (1..=looks)
                .map(|k| {
                    law.threshold(p, k as f64 * segment_s)
                        .map(|t| t.log_ratio)
                        .unwrap_or_else(|e| fail(&e.to_string()))
                })
                .collect()
        })
        .collect();
    let top = law
        .threshold(PFAS[0], LIMIT_S)
        .unwrap_or_else(|e| fail(&e.to_string()));
    eprintln!(
        "noise law: {draws} draws of {LIMIT_S} s in {:.0} s; thresholds at the limit {:?}",
        started.elapsed().as_secs_f64(),
        thresholds
            .iter()
            .map(|t| (t[looks - 1] * 100.0).round() / 100.0)
            .collect::<Vec<_>>()
    );

    // The bound's searched-position threshold for the kernel family.
    let table = kernel_table();
    let eta = glrt_threshold(&table, BOUND_PFA, 50_000, &mut || rng.next())
        .unwrap_or_else(|e| fail(&e.to_string()));
    let needed = snr_needed(eta, BOUND_PD).unwrap_or_else(|e| fail(&e.to_string()));

    let run = |amplitude_per_beat_snr: Option<f64>, rng: &mut Normals| -> Trial {
        let rate = RATES_HZ.0 + (RATES_HZ.1 - RATES_HZ.0) * rng.uniform();
        let period = 1.0 / rate;
        let x0 = REACH_M * (2.0 * rng.uniform() - 1.0);
        let amplitude = amplitude_per_beat_snr.map_or(0.0, |snr| {
            amplitude_for(snr, x0, period).unwrap_or_else(|e| fail(&e))
        });
        let mut detector = WeakPulseDetector::new(settings.clone(), PulseShape::Generic, &top)
            .unwrap_or_else(|e| fail(&e.to_string()));
        let running_max = feed(&mut detector, amplitude, x0, period, looks, rng);
        Trial {
            period_s: period,
            running_max,
        }
    };

    let started = std::time::Instant::now();
    let noise: Vec<Trial> = (0..trials).map(|_| run(None, &mut rng)).collect();
    eprintln!(
        "noise only: {trials} trials in {:.0} s",
        started.elapsed().as_secs_f64()
    );

    println!(
        "weak_pulse_roc: {trials} trials per strength and of noise only, seed {seed}, noise law {draws} draws; element noise {} mN at {FS_HZ} Hz, kernel width {} mm, heart {}-{} Hz, beat intervals varying ~4.6 %",
        SIGMA_N * 1e3,
        WIDTH_M * 1e3,
        RATES_HZ.0,
        RATES_HZ.1
    );
    println!(
        "bound: position searched over ±11 mm, threshold {eta:.3} (pfa {BOUND_PFA}), SNR needed {needed:.3} (pd {BOUND_PD})"
    );
    for &b in &STRENGTHS_BEATS {
        let started = std::time::Instant::now();
        let per_beat_snr = needed / b.sqrt();
        let pulses: Vec<Trial> = (0..trials)
            .map(|_| run(Some(per_beat_snr), &mut rng))
            .collect();
        eprintln!(
            "{b} bound beats: {trials} trials in {:.0} s",
            started.elapsed().as_secs_f64()
        );
        report(
            b,
            per_beat_snr,
            &table,
            &thresholds,
            &noise,
            &pulses,
            segment_s,
            looks,
            &mut rng,
        );
    }
}

/// One run: the heart's mean period and the log ratio's running maximum at each segment end
/// (carried on past a decision: it only grows).
struct Trial {
    period_s: f64,
    running_max: Vec<f64>,
}

impl Trial {
    /// Segments in a window of `beats` of this trial's heart, within the limit.
    fn segments(&self, beats: f64, segment_s: f64, looks: usize) -> usize {
        ((beats * self.period_s / segment_s).ceil() as usize).clamp(1, looks)
    }

    fn alarms(&self, k: usize, thresholds: &[f64]) -> bool {
        self.running_max[k - 1] > thresholds[k - 1]
    }

    /// The first segment (1-based) whose statistic crosses a window of `k` segments'
    /// threshold, if any by `k`.
    fn decided_at(&self, k: usize, thresholds: &[f64]) -> Option<usize> {
        (1..=k).find(|&j| self.running_max[j - 1] > thresholds[k - 1])
    }
}

#[allow(clippy::too_many_arguments)]
fn report(
    bound_beats: f64,
    per_beat_snr: f64,
    table: &[(f64, [f64; ELEMENTS])],
    thresholds: &[Vec<f64>],
    noise: &[Trial],
    pulses: &[Trial],
    segment_s: f64,
    looks: usize,
    rng: &mut Normals,
) {
    let window_beats = WINDOW_X_BOUND * bound_beats;
    let fraction = |n: usize, of: usize| n as f64 / of.max(1) as f64;
    println!();
    println!(
        "strength: the bound decides in {bound_beats} beats (SNR {per_beat_snr:.3} per beat, position known)"
    );
    let given = pulses
        .iter()
        .map(|r| r.segments(window_beats, segment_s, looks) as f64 * segment_s / r.period_s)
        .sum::<f64>()
        / pulses.len().max(1) as f64;
    println!(
        "  window: {window_beats} beats rounded up to whole {segment_s} s segments, {given:.1} beats on average ({:.2}x the bound's)",
        given / bound_beats
    );
    println!(
        "  nominal pfa | window {window_beats} beats: measured pfa   pd   bound's pd | limit {LIMIT_S} s: measured pfa   pd"
    );
    for (p, t) in PFAS.iter().zip(thresholds) {
        let windowed = |trials: &[Trial]| {
            fraction(
                trials
                    .iter()
                    .filter(|r| r.alarms(r.segments(window_beats, segment_s, looks), t))
                    .count(),
                trials.len(),
            )
        };
        let limited = |trials: &[Trial]| {
            fraction(
                trials.iter().filter(|r| r.alarms(looks, t)).count(),
                trials.len(),
            )
        };
        let eta = glrt_threshold(table, *p, 50_000, &mut || rng.next()).unwrap_or(f64::NAN);
        // The bound's own pd at this pfa after the beats of each trial's window (the same
        // whole segments the detector is given): the true position's matched filter
        // crossing the searched threshold.
        let bound_pd = pulses
            .iter()
            .map(|r| {
                let beats =
                    r.segments(window_beats, segment_s, looks) as f64 * segment_s / r.period_s;
                1.0 - upper_tail(per_beat_snr * beats.sqrt() - eta)
            })
            .sum::<f64>()
            / pulses.len().max(1) as f64;
        println!(
            "  {p:11} | {:>28.3} {:>5.3} {:>11.3} | {:>22.3} {:>5.3}",
            windowed(noise),
            windowed(pulses),
            bound_pd,
            limited(noise),
            limited(pulses)
        );
    }
    let designed = PFAS
        .iter()
        .position(|&p| p == DESIGNED_PFA)
        .map_or(&thresholds[0], |i| &thresholds[i]);
    for (what, window) in [("window", Some(window_beats)), ("limit", None)] {
        let mut ratios: Vec<f64> = pulses
            .iter()
            .filter_map(|r| {
                let k = window.map_or(looks, |b| r.segments(b, segment_s, looks));
                r.decided_at(k, designed)
                    .map(|j| j as f64 * segment_s / r.period_s / bound_beats)
            })
            .collect();
        ratios.sort_by(f64::total_cmp);
        let q = |f: f64| {
            ratios
                .get(((ratios.len() as f64 - 1.0) * f).round() as usize)
                .copied()
                .unwrap_or(f64::NAN)
        };
        let within = |x: f64| fraction(ratios.iter().filter(|&&r| r <= x).count(), pulses.len());
        println!(
            "  decided at pfa {DESIGNED_PFA} over the {what}: {:.3} of trials; beats to decide / bound's: 10 % {:.2}, median {:.2}, 90 % {:.2}; within 1x {:.3}, 2x {:.3}, 4x {:.3}",
            fraction(ratios.len(), pulses.len()),
            q(0.1),
            q(0.5),
            q(0.9),
            within(1.0),
            within(2.0),
            within(4.0)
        );
    }
}

/// P(Z > x) for a unit normal, by bisection on the quantile (enough for a table).
fn upper_tail(x: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if normal_quantile(mid) < x {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    1.0 - 0.5 * (lo + hi)
}

fn kernel_at(x0: f64) -> [f64; ELEMENTS] {
    std::array::from_fn(|e| element_kernel((e as f64 - 4.5) * PITCH_M - x0, WIDTH_M, PITCH_M))
}

/// The kernel family over the detector's searched reach (±11 mm) in 0.5 mm steps.
fn kernel_table() -> Vec<(f64, [f64; ELEMENTS])> {
    (-22..=22)
        .map(|k| {
            let x = k as f64 * 0.0005;
            (x, kernel_at(x))
        })
        .collect()
}

/// The pulse's peak force on the nearest element, N, for which one beat at `x0` with mean
/// period `period_s` has matched-filter SNR `snr` (the bound's per-beat SNR is linear in it).
fn amplitude_for(snr: f64, x0: f64, period_s: f64) -> Result<f64, String> {
    let h = 0.000_25;
    let here: Vec<(f64, [f64; ELEMENTS])> = [x0 - h, x0, x0 + h]
        .iter()
        .map(|&x| (x, kernel_at(x)))
        .collect();
    let peak = kernel_at(x0).iter().copied().fold(0.0, f64::max);
    let w: Vec<f64> = (0..(period_s * FS_HZ).round() as usize)
        .map(|i| generic_pressure(i as f64 / FS_HZ, period_s) / peak)
        .collect();
    let unit = per_beat(&here, 1, waveform_energy(&w), SIGMA_N).map_err(|e| e.to_string())?;
    Ok(snr / unit.snr)
}

/// Feed frames until `looks` segment ends have been reported (or the detector stops); the
/// running maximum of the log ratio at each.
fn feed(
    detector: &mut WeakPulseDetector,
    amplitude_n: f64,
    x0: f64,
    period_s: f64,
    looks: usize,
    rng: &mut Normals,
) -> Vec<f64> {
    let onsets = if amplitude_n > 0.0 {
        beats(period_s, LIMIT_S + 10.0, rng)
    } else {
        Vec::new()
    };
    let s = kernel_at(x0);
    let peak = s.iter().copied().fold(0.0, f64::max);
    let mut running = Vec::with_capacity(looks);
    let mut top = f64::NEG_INFINITY;
    let mut heart = BeatCursor::new(onsets);
    for i in 0u64.. {
        let t = i as f64 / FS_HZ;
        let pulse = heart
            .at(t)
            .map_or(0.0, |(t0, rr)| generic_pressure(t - t0, rr));
        let frame = TactileFrame {
            t_s: t,
            seq: i,
            force_n: std::array::from_fn(|e| {
                amplitude_n * s[e] / peak * pulse + SIGMA_N * rng.next()
            }),
        };
        match detector.push(&frame) {
            Ok(Some(progress)) => {
                top = top.max(progress.log_ratio);
                running.push(top);
                if progress.decision.is_some() || running.len() >= looks {
                    break;
                }
            }
            Ok(None) => {}
            Err(e) => fail(&format!("frame {i}: {e}")),
        }
    }
    // After a decision at the highest threshold every lower one is crossed too.
    running.resize(looks, top);
    running
}

fn fail(message: &str) -> ! {
    eprintln!("weak_pulse_roc: {message}");
    std::process::exit(1)
}
