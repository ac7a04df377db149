//! Print every look of search trials on drawn regions, for studying where a search spends
//! its heartbeats: `cargo run --release -p pulsetrack-sim --example search_trace -- search
//! 9001 9010 [FAMILY]` (method, first seed, last seed, and a family to draw the rig from).

use control::frames::SurfacePoint;
use control::search::{SearchMethod, SearchParams};

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let method = SearchMethod::parse(args.get(1).map_or("search", String::as_str))
        .ok_or("method: search or raster")?;
    let first: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(9001);
    let last: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(first);
    let (cname, text) = config::shipped::SIM_CONFIG;
    let cfg = config::load_str(cname, text).map_err(|e| e.to_string())?;
    let family = match args.get(4) {
        Some(name) => Some(pulsetrack_sim::family::load(name, None).map_err(|e| e.to_string())?),
        None => None,
    };
    let seed_bench =
        pulsetrack_sim::scene::load("seed-arc-145", None).map_err(|e| e.to_string())?;
    for seed in first..=last {
        let base = match &family {
            Some(f) => f.draw(seed)?,
            None => seed_bench.clone(),
        };
        let d = pulsetrack_sim::search_scene::draw(&base, SurfacePoint::new(0.0, 0.0), 0.04, seed)?;
        let t = pulsetrack_sim::runner::search::run_search(
            &d.scene,
            &cfg,
            d.region,
            method,
            SearchParams::default(),
            seed,
        )
        .map_err(|e| e.to_string())?;
        let path = pulsetrack_sim::scene::ArteryPath::from_spec(&d.scene.artery.path)
            .map_err(|e| e.to_string())?;
        println!(
            "seed {seed}: artery {} ({:?}) end {} beats {} looks {} seed errors {:?}",
            d.artery_in_region, d.scene.artery.path, t.end, t.beats, t.looks, t.seed_errors_m
        );
        println!(
            "  asked: {}",
            t.asked
                .iter()
                .map(|p| format!("({:.1},{:.1})", p[0] * 1e3, p[1] * 1e3))
                .collect::<Vec<_>>()
                .join(" ")
        );
        for (r, truly) in &t.looks_made {
            let off = path.nearest(*truly).offset_m;
            println!(
                "  {:>5.1} s look {:>2} at ({:>6.1},{:>6.1}) mm, truly ({:>6.1},{:>6.1}), artery {:>6.1} mm off centre, {:.1} s: felt {:<28} p {:.3} heading {:>6.1} deg",
                r.t_s,
                r.looks,
                r.at.x_m * 1e3,
                r.at.z_m * 1e3,
                truly.x_m * 1e3,
                truly.z_m * 1e3,
                off * 1e3,
                r.duration_s,
                r.felt.map_or("-".to_string(), |f| format!(
                    "z {:.1} mm, {:.1} mN",
                    f.point.z_m * 1e3,
                    f.amplitude_n * 1e3
                )),
                r.p_present,
                r.heading_rad.to_degrees()
            );
        }
    }
    Ok(())
}
