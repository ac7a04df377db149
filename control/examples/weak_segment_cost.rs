//! Time the weak-pulse detector's frame push at several coherent segment lengths: the
//! common push (a frame folded in) and the push that ends a segment (correlations, the
//! spatial projection, the track's update and, once found, the fit). The tracker pushes on
//! the daemon's 100 Hz frame path, so the segment's end is what must fit in a frame period.
//! Medians and the largest of each kind, all lengths in one run (compare them, not the
//! absolute numbers, on a shared machine).
//!
//! Run: `cargo run --release -p pulsetrack-control --example weak_segment_cost [-- SEGMENTS_S...]`
//! (default 3 6 10 15).

extern crate pulsetrack_control as control;

// Random numbers: the crate's test generator, included by path as in `weak_noise_table`.
#[path = "../src/test_normals.rs"]
mod test_normals;

use std::hint::black_box;
use std::time::Instant;

use control::signal::weak_pulse::{NoiseLaw, PulseShape, WeakPulseDetector, WeakPulseSettings};
use control::types::TactileFrame;
use test_normals::Normals;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<(), String> {
    let segments: Vec<f64> = std::env::args()
        .skip(1)
        .map(|s| s.parse::<f64>().map_err(|e| format!("{s}: {e}")))
        .collect::<Result<_, _>>()?;
    let segments = if segments.is_empty() {
        vec![3.0, 6.0, 10.0, 15.0]
    } else {
        segments
    };
    let limit_s = 120.0;
    println!(
        "segment s  segments  push median us  segment end: median us  max us  (per frame, averaged us)"
    );
    for segment_s in segments {
        let settings = WeakPulseSettings {
            segment_s,
            limit_s,
            ..WeakPulseSettings::default()
        };
        let mut noise = Normals::new(1);
        // A threshold crossed at once, and weighing on after it: every segment's end then
        // also fits the place (the slowest case).
        let law = NoiseLaw::measure(&settings, &PulseShape::Generic, 20, &mut || noise.next())
            .map_err(|e| e.to_string())?;
        let mut threshold = law.threshold(0.5, limit_s).map_err(|e| e.to_string())?;
        threshold.log_ratio = f64::NEG_INFINITY;
        let mut detector =
            WeakPulseDetector::new(settings.clone(), PulseShape::Generic, &threshold)
                .map_err(|e| e.to_string())?;
        let fs = settings.geometry.sample_rate_hz;
        let (mut common, mut ends) = (Vec::new(), Vec::new());
        let frames = (limit_s * fs) as u64;
        let started = Instant::now();
        for i in 0..frames {
            let frame = TactileFrame {
                t_s: i as f64 / fs,
                seq: i,
                force_n: std::array::from_fn(|_| 0.012 * noise.next()),
            };
            let t0 = Instant::now();
            let report = detector
                .push(black_box(&frame))
                .map_err(|e| e.to_string())?;
            let us = t0.elapsed().as_secs_f64() * 1e6;
            if report.is_some() {
                ends.push(us);
            } else {
                common.push(us);
            }
            detector.keep_weighing();
        }
        let average = started.elapsed().as_secs_f64() * 1e6 / frames as f64;
        let top = ends.iter().copied().fold(0.0, f64::max);
        println!(
            "{segment_s:9}  {:8}  {:14.2}  {:22.0}  {top:6.0}  ({average:.1})",
            ends.len(),
            median(common),
            median(ends),
        );
    }
    Ok(())
}
