//! The pulse period at rest never locks at half or double the heart rate: a fast,
//! irregular heart (issue 13: 1.6 Hz, beat interval SD 0.12 s), a pulse with a strong
//! second harmonic, a flat window, and heart rates 0.8-1.8 Hz with up to 20 % jitter.
//!
//! Each case runs [`PulseSearch`] as `beatslide` does: four-second windows at rest, one
//! search instance per trial (so the beat intervals of earlier windows are pooled), the
//! later searches narrowed to ±30 % around the clock's period, which may be the wrong one.

extern crate pulsetrack_control as control;

mod support;

use control::signal::pulse_search::{PulseSearch, PulseSearchSettings, SearchMiss};
use control::types::{ELEMENTS, TactileFrame};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use support::synth::{AcquisitionSpec, Rng, Waveform, acquisition, element_gain};

const WINDOW_SAMPLES: usize = 400;
/// Windows pooled before the period must hold (one window holds six beats).
const SETTLE: usize = 2;

fn settings(around_s: Option<f64>) -> PulseSearchSettings {
    let (lo, hi) = around_s.map_or((0.45, 2.2), |p| ((0.7 * p).max(0.45), (1.3 * p).min(2.2)));
    PulseSearchSettings {
        min_period_s: lo,
        max_period_s: hi,
        threshold: 8.0,
        decimation: 4,
        min_cycles: 2.5,
        coherent_s: 12.0,
        plausible_min_period_s: 0.45,
        plausible_max_period_s: 2.2,
    }
}

/// Periods found in `windows` successive windows of one heart; `around` gives the
/// narrowed range of each search after the first (None: the full range).
fn periods(
    rate_hz: f64,
    jitter: f64,
    swing_n: f64,
    windows: usize,
    around: impl Fn(usize) -> Option<f64>,
    seed: u64,
) -> Vec<Option<f64>> {
    let mut rng = Rng::new(seed);
    let mut search = PulseSearch::new(2 * WINDOW_SAMPLES);
    (0..windows)
        .map(|w| {
            let spec = AcquisitionSpec::seed_bench(
                WINDOW_SAMPLES,
                Waveform::Physiological { rate_hz, jitter },
                swing_n,
            );
            let frames = acquisition(&spec, rng.uniform(), 10.0 * w as f64, 0, &mut rng);
            search
                .search(frames.iter(), 0.012, &settings(around(w)))
                .ok()
                .map(|f| f.phase.period_s)
        })
        .collect()
}

#[test]
fn half_rate_lock_refused_on_a_synthetic_1_6_hz_pulse() {
    // Interval SD 0.12 s of 0.625 s. Before the beat-interval check, 7 of 30 such windows
    // gave about 1.25 s from the full range, and 27 of 30 searches narrowed around 1.25 s
    // (a clock at half rate) stayed there.
    let truth = 0.625;
    for seed in 1..=8 {
        for around in [None, Some(2.0 * truth)] {
            let found = periods(
                1.6,
                0.12 / truth,
                0.03,
                8,
                |w| around.filter(|_| w > 0),
                seed,
            );
            // From the third window on (one window is a handful of beats) every period
            // is within 35 % of the heart's (the mean of six intervals with a 19 % SD
            // scatters by 8 %; half rate would be 100 % off), and their median within 15 %.
            let mut later: Vec<f64> = found
                .iter()
                .skip(SETTLE)
                .map(|p| p.unwrap_or_else(|| panic!("seed {seed}: a window found nothing")))
                .collect();
            for p in &later {
                assert!(
                    (p / truth - 1.0).abs() < 0.35,
                    "seed {seed}, narrowed around {around:?}: {p:.3} s in {found:?}"
                );
            }
            later.sort_by(f64::total_cmp);
            let median = later[later.len() / 2];
            assert!(
                (median / truth - 1.0).abs() < 0.15,
                "seed {seed}, narrowed around {around:?}: median {median:.3} s of {found:?}"
            );
        }
    }
}

/// A regular pulse whose second harmonic is 1.3 times its fundamental (a strong dicrotic
/// wave), on an artery under element 4.5.
fn dicrotic_frames(period_s: f64, t0_s: f64, rng: &mut Rng) -> Vec<TactileFrame> {
    let gains: [f64; ELEMENTS] =
        std::array::from_fn(|e| element_gain((e as f64 - 4.5) * 0.002, 0.005, 0.002));
    (0..WINDOW_SAMPLES)
        .map(|j| {
            let t = t0_s + j as f64 * 0.01;
            let phi = std::f64::consts::TAU * t / period_s;
            let wave = 0.5 * (phi.cos() + 1.3 * (2.0 * phi).cos());
            TactileFrame {
                t_s: t,
                seq: j as u64,
                force_n: std::array::from_fn(|e| {
                    0.3 + 0.02 * gains[e] * wave + 0.012 * rng.normal()
                }),
            }
        })
        .collect()
}

#[test]
fn double_rate_lock_refused_on_a_strong_second_harmonic() {
    // A 0.9 Hz heart (1.11 s) whose second harmonic dominates: searched over the whole
    // range or up to 1.3 times the heart's period (holding half of it too), every window
    // gives the heart's period, never half of it. (A narrowed search never moves to a
    // period longer than its range, see pulse_search; the clock cannot walk there either,
    // see beat_clock's tests.)
    let truth = 1.0 / 0.9;
    for seed in 1..=8 {
        let mut rng = Rng::new(seed);
        let mut search = PulseSearch::new(2 * WINDOW_SAMPLES);
        for w in 0..4 {
            let frames = dicrotic_frames(truth, 10.0 * w as f64, &mut rng);
            let narrowed = PulseSearchSettings {
                min_period_s: 0.45,
                max_period_s: 1.3 * truth,
                ..settings(None)
            };
            let range = if w % 2 == 0 { settings(None) } else { narrowed };
            let found = search
                .search(frames.iter(), 0.012, &range)
                .expect("a clear pulse");
            let p = found.phase.period_s;
            assert!(
                (p / truth - 1.0).abs() < 0.1,
                "seed {seed}, window {w}: {p:.3} s against {truth:.3} s"
            );
        }
    }
}

#[test]
fn a_flat_window_gives_no_period() {
    let mut search = PulseSearch::new(2 * WINDOW_SAMPLES);
    let flat: Vec<TactileFrame> = (0..WINDOW_SAMPLES)
        .map(|j| TactileFrame {
            t_s: j as f64 * 0.01,
            seq: j as u64,
            force_n: [0.3; ELEMENTS],
        })
        .collect();
    for around in [None, Some(0.625)] {
        match search.search(flat.iter(), 0.012, &settings(around)) {
            Err(SearchMiss::BelowThreshold { .. }) => {}
            other => panic!("a flat window gave {other:?}"),
        }
    }
}

#[test]
fn never_near_half_or_double_for_rates_0_8_to_1_8_hz_and_jitter_up_to_20_percent() {
    // Deterministic: a fixed generator, so a failure reproduces.
    let config = Config {
        cases: 48,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let strategy = (0.8f64..1.8, 0.0f64..0.2, 0.02f64..0.04, any::<u64>());
    runner
        .run(&strategy, |(rate_hz, jitter, swing_n, seed)| {
            let truth = 1.0 / rate_hz;
            let found = periods(rate_hz, jitter, swing_n, 4, |_| None, seed);
            // The pooled estimate (after the first window) is never within 25 % of half
            // or double the heart's period.
            for p in found.iter().skip(1).flatten() {
                let ratio = p / truth;
                prop_assert!(
                    !(0.375..=0.625).contains(&ratio) && !(1.5..=2.5).contains(&ratio),
                    "{rate_hz:.2} Hz, jitter {jitter:.2}: {p:.3} s ({ratio:.2} of the period): {found:?}"
                );
            }
            Ok(())
        })
        .expect("no half- or double-rate period");
}
