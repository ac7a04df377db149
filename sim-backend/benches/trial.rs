//! Speed of whole lockstep trials: simulated seconds per wall second, medians over seeds.
//!
//! `cargo bench -p pulsetrack-sim --bench trial`. One trial is a whole seed experiment (two
//! placements, two marks, then tracking to the end) with full physics: the Phantom under the
//! PD at 1 kHz, the compliant rod and pivot, friction, 100 Hz frames through the kernel, and
//! the `seed2002` tracker. The ideal-robot rows drop the arm dynamics (a scene without a
//! `robot` section) to show what a signal-processing scene pays.

use std::time::Instant;

use pulsetrack_sim::runner::run_trial;
use pulsetrack_sim::scene;

const SEEDS: u64 = 7;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let (name, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = match config::load_str(name, text) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    println!(
        "{:<22} {:>6} {:>12} {:>12} {:>12} {:>10}",
        "scene", "robot", "simulated s", "wall ms", "x real time", "ns/step"
    );
    for scene_name in [
        "seed-arc-220.ron",
        "seed-arc-145.ron",
        "seed-arc-80.ron",
        "seed-s-curve.ron",
    ] {
        let Ok(full) = scene::load(scene_name, None) else {
            eprintln!("cannot load {scene_name}");
            std::process::exit(1);
        };
        let mut ideal = full.clone();
        ideal.robot = None;
        for (label, s) in [("full", &full), ("ideal", &ideal)] {
            let (mut sim, mut wall, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
            for seed in 1..=SEEDS {
                let t0 = Instant::now();
                let Ok(t) = run_trial(s, &config, "seed2002", seed) else {
                    eprintln!("{scene_name} seed {seed} failed");
                    std::process::exit(1);
                };
                let w = t0.elapsed().as_secs_f64();
                sim.push(t.simulated_s);
                wall.push(w);
                ratio.push(t.simulated_s / w);
            }
            let (sim, wall, ratio) = (median(sim), median(wall), median(ratio));
            println!(
                "{:<22} {:>6} {:>12.1} {:>12.1} {:>12.0} {:>10.0}",
                scene_name,
                label,
                sim,
                wall * 1e3,
                ratio,
                1e9 / (ratio * 1000.0)
            );
        }
    }
}
