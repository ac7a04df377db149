//! What the array's hand (`SimArm::array_hand`, polled once per control step so that the
//! daemon's `place_array` hook takes effect at the next step) costs the simulated arm's 1 kHz
//! step: the same disabled arm stepped with and without a hand, interleaved rounds, medians.
//!
//! `cargo run --release -p pulsetrack-sim --example array_hand_cost -- [ROUNDS]`

use std::time::Instant;

use control::ports::Manipulator;
use control::types::JointTorques;
use pulsetrack_sim::rig::{SimArm, SimRig};

const STEPS: u32 = 20_000;

fn arm(hand: bool) -> Result<(SimArm, Option<pulsetrack_sim::rig::ArrayHand>), String> {
    let scene = pulsetrack_sim::scene::load("seed-arc-145.ron", None).map_err(|e| e.to_string())?;
    let (name, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(name, text).map_err(|e| e.to_string())?;
    let rig = SimRig::new(&scene, &config, 1).map_err(|e| e.to_string())?;
    let (mut arm, _tactile) = rig.split();
    let h = hand.then(|| arm.array_hand());
    Ok((arm, h))
}

/// Wall time per step, ns.
fn per_step(arm: &mut SimArm) -> Result<f64, String> {
    let zero = JointTorques::default();
    let t = Instant::now();
    for _ in 0..STEPS {
        arm.write_torques(&zero).map_err(|e| e.to_string())?;
    }
    Ok(t.elapsed().as_nanos() as f64 / f64::from(STEPS))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), String> {
    let rounds: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().map_err(|e| format!("{s}: {e}")))
        .transpose()?
        .unwrap_or(15);
    let (mut without, _) = arm(false)?;
    let (mut with, _hand) = arm(true)?;
    let (mut a, mut b, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        let x = per_step(&mut without)?;
        let y = per_step(&mut with)?;
        a.push(x);
        b.push(y);
        ratio.push(y / x);
    }
    println!(
        "per step, median of {rounds} rounds of {STEPS}: without a hand {:.0} ns, with {:.0} ns, ratio {:.3}",
        median(&mut a),
        median(&mut b),
        median(&mut ratio)
    );
    Ok(())
}
