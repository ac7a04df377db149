//! Measure `beatslide`'s detector at rest (`PulseSearch` + `fit_kernel`) on synthetic
//! acquisitions: the null distribution of its statistic (noise only, with contact offsets
//! and creep drift), and detection and localization against the pulse swing.
//!
//! Run: `cargo run --release -p pulsetrack-control --example pulse_search_sweep [-- TRIALS [SEED]]`
//! (default 400 trials per cell, seed 7). docs/tracker-beatslide.md records the output and
//! the threshold chosen from it.

extern crate pulsetrack_control as control;

#[path = "../tests/support/synth.rs"]
#[allow(dead_code)]
mod synth;

use control::sensor::ArrayGeometry;
use control::signal::kernel_fit::fit_kernel;
use control::signal::noise_level::NoiseLevel;
use control::signal::pulse_search::{PulseSearch, PulseSearchSettings, SearchMiss};
use synth::{AcquisitionSpec, Rng, Waveform, acquisition};

const WINDOWS_S: &[f64] = &[3.0, 4.0, 8.0, 16.0, 32.0];
const SWINGS_N: &[f64] = &[0.003, 0.006, 0.009, 0.012, 0.018, 0.024, 0.036];

fn main() {
    let mut args = std::env::args().skip(1);
    let trials: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(400);
    let seed: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(7);
    let mut rng = Rng::new(seed);
    let geometry = ArrayGeometry::default();
    let settings = PulseSearchSettings {
        min_period_s: 0.45,
        max_period_s: 2.2,
        threshold: f64::INFINITY,
        decimation: 4,
        min_cycles: 2.5,
        coherent_s: std::env::var("COHERENT")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(12.0),
        plausible_min_period_s: 0.45,
        plausible_max_period_s: 2.2,
    };
    let mut search = PulseSearch::new(4000);
    let mut noise = NoiseLevel::new(4000);

    println!("## Null distribution of the statistic (noise only, {trials} windows each)\n");
    println!("| window s | median | p90 | p99 | p99.9 | max |");
    println!("|---|---|---|---|---|---|");
    for &w in WINDOWS_S {
        let mut stats = Vec::with_capacity(trials);
        for _ in 0..trials {
            let spec = AcquisitionSpec {
                artery_element: None,
                drift_n: rng.range(-0.03, 0.03),
                ..AcquisitionSpec::seed_bench(
                    (w * 100.0) as usize,
                    Waveform::Sine { rate_hz: 1.0 },
                    0.0,
                )
            };
            let frames = acquisition(&spec, rng.uniform(), 10.0, 0, &mut rng);
            let sigma = noise.estimate(frames.iter()).unwrap_or(0.012).max(0.012);
            // Every window is another heart: no pooling of beat intervals.
            search.forget_beats();
            let s = match search.search(frames.iter(), sigma, &settings) {
                Err(SearchMiss::BelowThreshold { statistic, .. }) => statistic,
                Ok(found) => found.statistic,
                Err(e) => panic!("{e}"),
            };
            stats.push(s);
        }
        stats.sort_by(f64::total_cmp);
        let q = |p: f64| stats[((p * trials as f64) as usize).min(trials - 1)];
        println!(
            "| {w} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            q(0.5),
            q(0.9),
            q(0.99),
            q(0.999),
            stats[trials - 1]
        );
    }

    let threshold = std::env::var("THRESHOLD")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(8.0);
    let settings = PulseSearchSettings {
        threshold,
        ..settings
    };
    println!(
        "\n## Detection at threshold {threshold} (found and within 1 mm / median |error| mm of found)\n"
    );
    let mut header = String::from("| waveform | window s |");
    for s in SWINGS_N {
        header.push_str(&format!(" {:.0} mN |", s * 1e3));
    }
    println!("{header}");
    println!("|---|---|{}", "---|".repeat(SWINGS_N.len()));
    for (name, wave) in [
        (
            "square 0.9-1.1 Hz",
            (|r: &mut Rng| Waveform::Square {
                rate_hz: r.range(0.9, 1.1),
                tau_s: 0.03,
            }) as fn(&mut Rng) -> Waveform,
        ),
        ("physiological 1.0-1.67 Hz", |r: &mut Rng| {
            Waveform::Physiological {
                rate_hz: r.range(1.0, 1.67),
                jitter: 0.03,
            }
        }),
    ] {
        for &w in WINDOWS_S {
            let mut row = format!("| {name} | {w} |");
            for &swing in SWINGS_N {
                let (mut ok, mut errors) = (0usize, Vec::new());
                for _ in 0..trials {
                    let artery = rng.range(1.5, 7.5);
                    let spec = AcquisitionSpec {
                        artery_element: Some(artery),
                        drift_n: rng.range(-0.03, 0.03),
                        ..AcquisitionSpec::seed_bench((w * 100.0) as usize, wave(&mut rng), swing)
                    };
                    let frames = acquisition(&spec, rng.uniform(), 10.0, 0, &mut rng);
                    let sigma = noise.estimate(frames.iter()).unwrap_or(0.012).max(0.012);
                    search.forget_beats();
                    let Ok(found) = search.search(frames.iter(), sigma, &settings) else {
                        continue;
                    };
                    let se = found.amplitudes.se_per_sigma * sigma;
                    let Ok(fit) = fit_kernel(&found.amplitudes.amplitude_n, se, &geometry) else {
                        continue;
                    };
                    let err_mm = (fit.element - artery).abs() * 2.0;
                    if err_mm <= 1.0 {
                        ok += 1;
                    }
                    errors.push(err_mm);
                }
                errors.sort_by(f64::total_cmp);
                let median = errors.get(errors.len() / 2).copied().unwrap_or(f64::NAN);
                row.push_str(&format!(
                    " {:.0} % / {:.2} |",
                    100.0 * ok as f64 / trials as f64,
                    median
                ));
            }
            println!("{row}");
        }
    }
}
