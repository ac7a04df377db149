//! Where the lateral error of each located point comes from: the robot's belief against the
//! sensor's true position (compliance, friction, attitude), and the localization on the
//! array relative to the true sensor (pitch, noise, crossing angle). Runs `seed2002` on a
//! scene, trials with seeds `1..=N`, autonomous points only.
//!
//! `cargo run --release -p pulsetrack-sim --example error_breakdown -- SCENE [TRIALS]`
//!
//! For a located point `L` (believed sensor centre `B` plus the element offset along the
//! line), the true sensor centre `T` and the path normal `n` at the nearest path point:
//! `n·(L − path) = n·(B − T) + n·(T + offset − path)`: the first term is the belief error,
//! the second the array's. The belief error is split further into its part along the last
//! move (the lag of a sliding, compliant sensor) and across it.

use pulsetrack_sim::runner::run_trial;
use pulsetrack_sim::scene::ArteryPath;
use pulsetrack_sim::trial_event::EventKind;

fn stats(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    if v.len() < 2 {
        return (f64::NAN, f64::NAN);
    }
    let m = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (m, sd)
}

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let (ma, sa) = stats(a);
    let (mb, sb) = stats(b);
    let n = a.len() as f64;
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - ma) * (y - mb))
        .sum::<f64>()
        / ((n - 1.0) * sa * sb)
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args
        .first()
        .ok_or("usage: error_breakdown SCENE [TRIALS]")?;
    let trials: u64 = match args.get(1) {
        Some(a) => a.parse().map_err(|e| format!("{a}: {e}"))?,
        None => 3,
    };
    let scene = pulsetrack_sim::scene::load(name, None).map_err(|e| e.to_string())?;
    let (cname, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(cname, text).map_err(|e| e.to_string())?;
    let path = ArteryPath::from_spec(&scene.artery.path).map_err(|e| e.to_string())?;
    let (mut total, mut belief, mut array, mut lag, mut cross) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut belief_x, mut belief_z) = (Vec::new(), Vec::new());
    for seed in 1..=trials {
        let t = run_trial(&scene, &config, "seed2002", seed).map_err(|e| e.to_string())?;
        println!(
            "trial {seed}: {} points, SD {:.2} mm, mean {:.2} mm, {} backtracks, {}",
            t.lateral_error_m.points,
            t.lateral_error_m.sd * 1e3,
            t.lateral_error_m.mean * 1e3,
            t.backtracks,
            t.end_reason
        );
        // The misses and backtracks, with where the sensor truly was against the artery.
        for event in t.log.iter().filter(|e| {
            matches!(
                e.event,
                EventKind::Missed { .. } | EventKind::Backtracking { .. }
            )
        }) {
            println!("    {}", event.describe());
        }
        let mut previous: Option<(f64, f64)> = None;
        for p in &t.located {
            let here = (p.true_x_m, p.true_z_m);
            let Some(&(_, believed, truth)) = t
                .sensor_track
                .iter()
                .min_by(|a, b| (a.0 - p.t_s).abs().total_cmp(&(b.0 - p.t_s).abs()))
            else {
                continue;
            };
            let near = path.nearest(control::frames::SurfacePoint::new(p.x_m, p.z_m));
            let (nx, nz) = (-near.heading_rad.sin(), near.heading_rad.cos());
            let (bx, bz) = (believed.x_m - truth.x_m, believed.z_m - truth.z_m);
            if !p.seed {
                let e_b = nx * bx + nz * bz;
                total.push(p.lateral_error_m);
                belief.push(e_b);
                array.push(p.lateral_error_m - e_b);
                belief_x.push(bx);
                belief_z.push(bz);
                if let Some((px, pz)) = previous {
                    let (dx, dz) = (here.0 - px, here.1 - pz);
                    let d = dx.hypot(dz).max(1e-9);
                    lag.push((bx * dx + bz * dz) / d);
                    cross.push((-bx * dz + bz * dx) / d);
                }
            }
            previous = Some(here);
        }
    }
    let mm = |v: &[f64]| {
        let (m, s) = stats(v);
        format!("mean {:+.2} mm, SD {:.2} mm", m * 1e3, s * 1e3)
    };
    println!("{}: {} autonomous points", scene.name, total.len());
    println!("  total lateral error          {}", mm(&total));
    println!("  belief − truth, lateral      {}", mm(&belief));
    println!("  array (true sensor → report) {}", mm(&array));
    println!(
        "  correlation belief/array     {:+.2}",
        corr(&belief, &array)
    );
    println!("  belief − truth along x       {}", mm(&belief_x));
    println!("  belief − truth along z       {}", mm(&belief_z));
    println!("  ... along the last move      {}", mm(&lag));
    println!("  ... across the last move     {}", mm(&cross));
    Ok(())
}
