//! The noise-free swing (max − min over 10 s) of each element with the sensor held by the
//! ideal robot at a scene's first placement (or at `X Z`, mm), for calibration checks.
//!
//! `cargo run --release -p pulsetrack-sim --example element_swing -- SCENE [X_MM Z_MM]`

use control::frames::SurfacePoint;
use pulsetrack_sim::bench::Bench;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args
        .first()
        .ok_or("usage: element_swing SCENE [X_MM Z_MM]")?;
    let scene = pulsetrack_sim::scene::load(name, None).map_err(|e| e.to_string())?;
    let at = match (args.get(1), args.get(2)) {
        (Some(x), Some(z)) => {
            let p = |s: &String| s.parse::<f64>().map_err(|e| format!("{s}: {e}"));
            SurfacePoint::new(p(x)? * 1e-3, p(z)? * 1e-3)
        }
        _ => scene.placements[0],
    };
    let (cname, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(cname, text).map_err(|e| e.to_string())?;
    let mut bench = Bench::new(&scene, &config, 1, true).map_err(|e| e.to_string())?;
    bench.place_ideal(at);
    let (mut lo, mut hi) = ([f64::MAX; 10], [f64::MIN; 10]);
    for _ in 0..10_000 {
        bench.step();
        let f = bench.clean_forces();
        for ((l, h), v) in lo.iter_mut().zip(hi.iter_mut()).zip(f) {
            *l = l.min(v);
            *h = h.max(v);
        }
    }
    println!(
        "{} at ({:.1}, {:.1}) mm: swing per element (mN)",
        scene.name,
        at.x_m * 1e3,
        at.z_m * 1e3
    );
    for (l, h) in lo.iter().zip(&hi) {
        print!("{:>6.1}", (h - l) * 1e3);
    }
    println!();
    Ok(())
}
