//! Measure pulse detection against the band-pass order on synthetic acquisitions.
//!
//! For each FIR order, runs the seed's full signal chain (`PulseAnalyzer`: band-pass,
//! detection, 2σ localization) on synthetic windows: the seed's solenoid square wave at
//! 0.9-1.1 Hz and a physiological pulse at 1.0-1.67 Hz, 3 s and 4 s windows, pulse swings
//! from half to six times the 0.012 N noise SD, the artery anywhere between elements 1.5
//! and 7.5, contact offsets and a creep drift of up to ±0.03 N per window. Reports:
//! - `det`: found and located within one element of the truth, % of trials;
//! - `wrong`: found but more than one element off, %;
//! - `perr`: median |period error| of found windows, %;
//! - `false`: noise-only windows (no artery) reported as found, %.
//!
//! Run: `cargo run --release -p pulsetrack-control --example fir_order_sweep [-- TRIALS [SEED]]`
//! (default 200 trials per cell, seed 2002).
//! docs/signal-processing.md records the output and the choice of the shipped order.

extern crate pulsetrack_control as control;

#[path = "../tests/support/synth.rs"]
#[allow(dead_code)]
mod synth;

use control::sensor::ArrayGeometry;
use control::signal::window::AcquisitionWindow;
use control::signal::{PulseAnalyzer, RunningPeriod};
use control::tracker::seed2002::{Seed2002, Seed2002Params};
use synth::{AcquisitionSpec, Rng, Waveform, acquisition};

const ORDERS: &[usize] = &[4, 8, 16, 32, 48, 64, 80, 96, 112, 128, 160, 192, 256, 384];
/// Orders also measured with localization on the raw forces (`localize_filtered: false`).
const RAW_ORDERS: &[usize] = &[64, 96, 128, 192];
const SWINGS_N: &[f64] = &[0.006, 0.012, 0.018, 0.024, 0.036, 0.048, 0.072];
const WINDOWS_S: &[f64] = &[3.0, 4.0];

#[derive(Clone, Copy)]
enum Kind {
    Square,
    Physiological,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Square => "square 0.9-1.1 Hz",
            Kind::Physiological => "physiological 1.0-1.67 Hz",
        }
    }

    fn draw(self, rng: &mut Rng) -> Waveform {
        match self {
            Kind::Square => Waveform::Square {
                rate_hz: rng.range(0.9, 1.1),
                tau_s: 0.05,
            },
            Kind::Physiological => Waveform::Physiological {
                rate_hz: rng.range(1.0, 1.67),
                jitter: 0.03,
            },
        }
    }
}

struct Cell {
    detected: usize,
    wrong: usize,
    period_errors: Vec<f64>,
    trials: usize,
}

fn analyzer(
    order: usize,
    window_s: f64,
    localize_filtered: bool,
) -> (PulseAnalyzer, AcquisitionWindow) {
    let params = Seed2002Params {
        fir_order: order,
        localize_filtered,
        ..Seed2002Params::default()
    };
    let geometry = ArrayGeometry::default();
    let tracker = Seed2002::new(params, geometry).expect("valid parameters");
    let samples = (window_s * geometry.sample_rate_hz).round() as usize;
    (
        tracker.analyzer().clone(),
        AcquisitionWindow::new(samples, geometry.sample_rate_hz),
    )
}

fn run_cell(
    order: usize,
    window_s: f64,
    localize_filtered: bool,
    kind: Option<Kind>,
    swing_n: f64,
    trials: usize,
    rng: &mut Rng,
) -> Cell {
    let (mut analyzer, mut window) = analyzer(order, window_s, localize_filtered);
    let samples = window.capacity();
    let mut cell = Cell {
        detected: 0,
        wrong: 0,
        period_errors: Vec::new(),
        trials,
    };
    for _ in 0..trials {
        let waveform = kind.map_or(Waveform::Sine { rate_hz: 1.0 }, |k| k.draw(rng));
        let truth = rng.range(1.5, 7.5);
        let spec = AcquisitionSpec {
            artery_element: kind.map(|_| truth),
            drift_n: rng.range(-0.03, 0.03),
            ..AcquisitionSpec::seed_bench(samples, waveform, swing_n)
        };
        let frames = acquisition(&spec, rng.uniform(), 0.0, 0, rng);
        window.begin(samples);
        for f in &frames {
            window.push(f).expect("synthetic frames are consecutive");
        }
        if let Ok(found) = analyzer.analyse(&window, &RunningPeriod::new()) {
            if kind.is_none() || (found.localization.element - truth).abs() > 1.0 {
                cell.wrong += 1;
            } else {
                cell.detected += 1;
                let true_period = 1.0 / waveform.rate_hz();
                cell.period_errors
                    .push((found.timing.period_s - true_period).abs() / true_period);
            }
        }
    }
    cell
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

fn pct(k: usize, n: usize) -> f64 {
    100.0 * k as f64 / n as f64
}

/// Totals per (localization source, order) over swings of at least 2σ.
struct SummaryRow {
    filtered: bool,
    order: usize,
    detected: usize,
    trials: usize,
    worst_false_pct: f64,
    period_errors: Vec<f64>,
}

fn print_table_head() {
    print!("| order |");
    for s in SWINGS_N {
        print!(" {s:.3} N det/wrong |");
    }
    println!(" perr @0.036 N | false |");
    print!("|---|");
    for _ in SWINGS_N {
        print!("---|");
    }
    println!("---|---|");
}

fn main() {
    let mut args = std::env::args().skip(1);
    let trials: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(200);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(2002);
    let noise_trials = trials * 5;
    println!(
        "FIR order sweep: {trials} trials per cell, {noise_trials} noise-only windows per row, seed {seed}"
    );
    println!("det/wrong/false in % of trials, perr = median |period error| in %\n");
    let mut summary: Vec<SummaryRow> = Vec::new();
    for filtered in [true, false] {
        for &window_s in WINDOWS_S {
            for kind in [Kind::Square, Kind::Physiological] {
                let on = if filtered { "filtered" } else { "raw" };
                println!(
                    "### {window_s} s window, {}, localized on {on} data",
                    kind.name()
                );
                print_table_head();
                let orders = if filtered { ORDERS } else { RAW_ORDERS };
                for &order in orders {
                    // The same draws for every order and both sources: paired comparisons.
                    let mut rng = Rng::new(seed ^ ((order as u64) << 8) ^ (window_s as u64));
                    let at = match summary
                        .iter()
                        .position(|r| r.filtered == filtered && r.order == order)
                    {
                        Some(i) => i,
                        None => {
                            summary.push(SummaryRow {
                                filtered,
                                order,
                                detected: 0,
                                trials: 0,
                                worst_false_pct: 0.0,
                                period_errors: Vec::new(),
                            });
                            summary.len() - 1
                        }
                    };
                    let row = &mut summary[at];
                    print!("| {order} |");
                    let mut perr = None;
                    for &swing in SWINGS_N {
                        let mut cell = run_cell(
                            order,
                            window_s,
                            filtered,
                            Some(kind),
                            swing,
                            trials,
                            &mut rng,
                        );
                        print!(
                            " {:.0} / {:.0} |",
                            pct(cell.detected, cell.trials),
                            pct(cell.wrong, cell.trials)
                        );
                        if swing >= 0.024 - 1e-12 {
                            row.detected += cell.detected;
                            row.trials += cell.trials;
                            row.period_errors.extend(&cell.period_errors);
                        }
                        if (swing - 0.036).abs() < 1e-12 {
                            perr = median(&mut cell.period_errors);
                        }
                    }
                    let noise =
                        run_cell(order, window_s, filtered, None, 0.0, noise_trials, &mut rng);
                    let false_pct = pct(noise.wrong, noise.trials);
                    row.worst_false_pct = row.worst_false_pct.max(false_pct);
                    match perr {
                        Some(p) => print!(" {:.1} |", 100.0 * p),
                        None => print!(" - |"),
                    }
                    println!(" {false_pct:.1} |");
                }
                println!();
            }
        }
    }
    println!("### Summary: swings of 2σ (0.024 N) and more, both waveforms, 3 s and 4 s windows");
    println!("| localized on | order | det % | median perr % | p90 perr % | worst false % |");
    println!("|---|---|---|---|---|---|");
    for mut row in summary {
        let p50 = median(&mut row.period_errors).map_or(f64::NAN, |p| 100.0 * p);
        let p90 = row
            .period_errors
            .get(row.period_errors.len() * 9 / 10)
            .map_or(f64::NAN, |p| 100.0 * p);
        println!(
            "| {} | {} | {:.1} | {p50:.2} | {p90:.2} | {:.1} |",
            if row.filtered { "filtered" } else { "raw" },
            row.order,
            pct(row.detected, row.trials),
            row.worst_false_pct,
        );
    }
}
