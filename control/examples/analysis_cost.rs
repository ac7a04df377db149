//! Time the seed's signal chain: one acquisition analysed (band-pass of 10 elements,
//! detection, localization) at the shipped order for 3 s and 4 s windows, and one
//! `Tracker::step` on a frame that only adds to the window. Medians of repeated runs.
//!
//! Run: `cargo run --release -p pulsetrack-control --example analysis_cost`

extern crate pulsetrack_control as control;

#[path = "../tests/support/synth.rs"]
#[allow(dead_code)]
mod synth;

use std::hint::black_box;
use std::time::Instant;

use control::frames::SurfacePoint;
use control::signal::{AcquisitionWindow, RunningPeriod};
use control::tracker::seed2002::{Seed2002, Seed2002Params};
use control::tracker::{Tracker, TrackerInput};
use synth::{AcquisitionSpec, Rng, Waveform, acquisition};

fn median_us(mut samples: Vec<f64>) -> f64 {
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

fn main() {
    let params = Seed2002Params::default();
    let tracker = Seed2002::new(params, Default::default()).expect("default params");
    let mut rng = Rng::new(1);
    println!("fir_order {}", params.fir_order);
    for samples in [300, 400] {
        let spec = AcquisitionSpec::seed_bench(
            samples,
            Waveform::Square {
                rate_hz: 1.0,
                tau_s: 0.05,
            },
            0.06,
        );
        let mut window = AcquisitionWindow::new(samples, 100.0);
        window.begin(samples);
        for f in acquisition(&spec, 0.2, 0.0, 0, &mut rng) {
            window.push(&f).expect("consecutive");
        }
        let mut analyzer = tracker.analyzer().clone();
        let mut times = Vec::new();
        for _ in 0..500 {
            let start = Instant::now();
            let found = analyzer.analyse(black_box(&window), &RunningPeriod::new());
            times.push(start.elapsed().as_secs_f64() * 1e6);
            black_box(found.is_ok());
        }
        println!(
            "analyse one {} s window: median {:.1} us",
            samples / 100,
            median_us(times)
        );
    }
    // A step that only appends a frame (the common case while acquiring).
    let mut t = tracker;
    t.mark().expect("mark");
    let spec = AcquisitionSpec::seed_bench(390, Waveform::Sine { rate_hz: 1.0 }, 0.06);
    let frames = acquisition(&spec, 0.0, 0.0, 0, &mut rng);
    let mut times = Vec::new();
    for f in &frames {
        let input = TrackerInput {
            frame: f,
            sensor: SurfacePoint::default(),
            settled: true,
            loaded_sensor: None,
        };
        let start = Instant::now();
        black_box(t.step(black_box(&input)));
        times.push(start.elapsed().as_secs_f64() * 1e6);
    }
    println!(
        "Tracker::step appending a frame: median {:.2} us",
        median_us(times)
    );
}
