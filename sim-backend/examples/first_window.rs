//! Print what each element felt during the first manual placement of a trial: the mean
//! reading in each half of the pulse period (the solenoid's on and off phases), their
//! difference (the pulse as the element felt it), and the mean load.
//!
//! `cargo run --release -p pulsetrack-sim --example first_window -- SCENE [SEED]`

use pulsetrack_sim::runner::run_trial;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let scene_name = args.next().ok_or("usage: first_window SCENE [SEED]")?;
    let seed: u64 = args
        .next()
        .map(|s| s.parse().map_err(|e| format!("seed: {e}")))
        .transpose()?
        .unwrap_or(1);
    let scene = pulsetrack_sim::scene::load(&scene_name, None).map_err(|e| e.to_string())?;
    let (name, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(name, text).map_err(|e| e.to_string())?;
    let t = run_trial(&scene, &config, "seed2002", seed).map_err(|e| e.to_string())?;
    let frames = &t.first_acquisition;
    println!(
        "{}: {} frames, end {}",
        scene.name,
        frames.len(),
        t.end_reason
    );
    let period = 1.0
        / match scene.pulse {
            pulsetrack_sim::scene::PulseSpec::Physiological { heart_rate_hz, .. } => heart_rate_hz,
            pulsetrack_sim::scene::PulseSpec::Solenoid { period_s, .. } => 1.0 / period_s,
            pulsetrack_sim::scene::PulseSpec::Absent => 1.0,
        };
    let (mut on, mut off) = ([0.0f64; 10], [0.0f64; 10]);
    let (mut n_on, mut n_off) = (0.0f64, 0.0f64);
    for f in frames {
        let phase = (f.t_s / period).fract();
        let (sum, n) = if phase < 0.5 {
            (&mut on, &mut n_on)
        } else {
            (&mut off, &mut n_off)
        };
        for i in 0..10 {
            sum[i] += f.force_n[i];
        }
        *n += 1.0;
    }
    println!("element  on-off (mN)  mean load (mN)");
    for i in 0..10 {
        let a = on[i] / n_on.max(1.0);
        let b = off[i] / n_off.max(1.0);
        println!(
            "{i:>7} {:>12.1} {:>15.1}",
            (a - b) * 1e3,
            0.5 * (a + b) * 1e3
        );
    }
    Ok(())
}
