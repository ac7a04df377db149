//! One trial's event log (every tracker event with the robot's belief and the sensor's true
//! place against the artery), for finding why a trial failed.
//!
//! `cargo run --release -p pulsetrack-sim --example trial_log -- SCENE TRACKER SEED`

use pulsetrack_sim::runner::run_trial;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(name), Some(tracker), Some(seed)) = (args.first(), args.get(1), args.get(2)) else {
        return Err("usage: trial_log SCENE TRACKER SEED".into());
    };
    let seed: u64 = seed.parse().map_err(|e| format!("{seed}: {e}"))?;
    let scene = pulsetrack_sim::scene::load(name, None).map_err(|e| e.to_string())?;
    let (cname, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(cname, text).map_err(|e| e.to_string())?;
    let t = run_trial(&scene, &config, tracker, seed).map_err(|e| e.to_string())?;
    for event in &t.log {
        println!("{}", event.describe());
    }
    println!(
        "{}: {} points, SD {:.2} mm, mean {:.2} mm, {} beats, {} backtracks, {:.1} s",
        t.end_reason,
        t.lateral_error_m.points,
        t.lateral_error_m.sd * 1e3,
        t.lateral_error_m.mean * 1e3,
        t.beats,
        t.backtracks,
        t.duration_s
    );
    for p in &t.located {
        println!(
            "  {:7.2} s  ({:6.2}, {:6.2}) mm  error {:5.2} mm at {:5.1} mm  SD {}{}",
            p.t_s,
            p.x_m * 1e3,
            p.z_m * 1e3,
            p.lateral_error_m * 1e3,
            p.along_path_m * 1e3,
            p.sd_m
                .map_or_else(|| "-".to_string(), |sd| format!("{:.2} mm", sd * 1e3)),
            if p.seed { "  seed" } else { "" }
        );
    }
    Ok(())
}
