//! Writes the weak-pulse detector's shipped threshold table
//! (`control/src/signal/weak_pulse/noise_table.rs`): its noise-only law, measured by Monte
//! Carlo on the detector itself with the tabulated settings
//! (`WeakPulseSettings::tabulated`, the generic waveform), as the log-ratio threshold at
//! each segment end for the false-alarm rates the tracker offers. Measuring it takes
//! minutes, too long for a tracker's start, and the law does not depend on the noise level
//! (the detector whitens by the noise it measures), so it is measured once and shipped;
//! `noise_table`'s test re-measures a short stretch of it against the table.
//!
//! Run: `cargo run --release -p pulsetrack-control --example weak_noise_table -- [DRAWS [SEED]] > control/src/signal/weak_pulse/noise_table.rs`
//! (default 2000 draws, seed 1818; about 15 minutes on one core).
//!
//! Random numbers: the crate's test generator (`control/src/test_normals.rs`) included by
//! path, as in `weak_pulse_roc`.

extern crate pulsetrack_control as control;

#[path = "../src/test_normals.rs"]
mod test_normals;

use control::signal::weak_pulse::{NoiseLaw, PulseShape, TABLE_PFAS, WeakPulseSettings};
use test_normals::Normals;

fn fail(what: &str) -> ! {
    eprintln!("weak_noise_table: {what}");
    std::process::exit(2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let parse = |i: usize, default: u64| -> u64 {
        args.get(i).map_or(default, |s| {
            s.parse().unwrap_or_else(|_| {
                fail(&format!("argument {} ({s:?}) is not a whole number", i + 1))
            })
        })
    };
    let draws = parse(0, 2000) as usize;
    let seed = parse(1, 1818);
    let settings = WeakPulseSettings::tabulated();
    let mut rng = Normals::new(seed);
    let started = std::time::Instant::now();
    let law = NoiseLaw::measure(&settings, &PulseShape::Generic, draws, &mut || rng.next())
        .unwrap_or_else(|e| fail(&e.to_string()));
    let looks = (settings.limit_s / settings.segment_s).round() as usize;
    println!(
        "//! The weak-pulse detector's noise-only law for `WeakPulseSettings::tabulated()` and the\n\
         //! generic waveform: for each false-alarm rate of `TABLE_PFAS`, the log-ratio threshold\n\
         //! over a window ending at each segment (the first entry: one segment).\n\
         //! Generated, do not edit: `cargo run --release -p pulsetrack-control --example\n\
         //! weak_noise_table -- {draws} {seed}` ({draws} noise-only draws of {} s, seed {seed}).\n",
        settings.limit_s
    );
    println!(
        "/// How many noise-only draws the table was measured on (its tests weigh its error by it).\n#[cfg(test)]\npub(super) const DRAWS: usize = {draws};"
    );
    println!(
        "pub(super) const THRESHOLDS: [[f64; {looks}]; {}] = [",
        TABLE_PFAS.len()
    );
    for &pfa in TABLE_PFAS.iter() {
        println!("    [");
        for k in 1..=looks {
            let t = law
                .threshold(pfa, k as f64 * settings.segment_s)
                .unwrap_or_else(|e| fail(&e.to_string()));
            println!("        {:?},", t.log_ratio);
        }
        println!("    ],");
    }
    println!("];");
    eprintln!(
        "weak_noise_table: {draws} draws in {:.0} s",
        started.elapsed().as_secs_f64()
    );
}
