//! Speed per path type (not a test): the nearest-point query through the index against the
//! full scan of every piece (what the query did before the index), and whole lockstep trials
//! in simulated seconds per second of this thread's CPU time (wall time on a shared machine
//! says little), median over seeds, `seed2002` on seed-arc-145's rig (full physics) with the
//! artery's course replaced by each path type.
//!
//! cargo run --release -p pulsetrack-sim --example path_speed [-- --seeds N]

use std::time::Instant;

use control::frames::SurfacePoint;
use pulsetrack_sim::runner::run_trial;
use pulsetrack_sim::scene::{self, ArteryPath, CurvatureKnot, PathSpec, Scene, TrackSpec, Turn};

/// The sine the spline and polyline rows are drawn through (amplitude, wavelength), m.
const SINE: (f64, f64) = (0.008, 0.12);

fn sine_points(step: f64) -> Vec<SurfacePoint> {
    let n = (0.2 / step).round() as usize;
    (0..=n)
        .map(|i| {
            let u = i as f64 * step;
            SurfacePoint::new(
                -0.1 + u,
                SINE.0 * (2.0 * std::f64::consts::PI * u / SINE.1).sin(),
            )
        })
        .collect()
}

fn courses() -> Vec<(&'static str, PathSpec)> {
    let origin = SurfacePoint::new(-0.1, 0.0);
    vec![
        (
            "spline (5 mm knots, 0.5 mm samples)",
            PathSpec::Spline {
                points: sine_points(0.005),
                sample_m: None,
            },
        ),
        (
            "polyline (2 mm segments)",
            PathSpec::Polyline {
                points: sine_points(0.002),
            },
        ),
        (
            "sinusoid",
            PathSpec::Sinusoid {
                start: origin,
                heading_rad: 0.0,
                amplitude_m: SINE.0,
                wavelength_m: SINE.1,
                length_m: 0.21,
                phase_rad: 0.0,
                step_m: None,
            },
        ),
        (
            "spiral",
            PathSpec::Spiral {
                start: SurfacePoint::new(-0.1, 0.03),
                heading_rad: -0.6,
                start_radius_m: 0.25,
                end_radius_m: 0.08,
                length_m: 0.2,
                turn: Turn::Left,
                step_m: None,
            },
        ),
        (
            "corners (30 deg, 2 mm fillets)",
            PathSpec::Corners {
                start: origin,
                heading_rad: 0.0,
                legs_m: vec![0.07, 0.07, 0.07],
                bends_rad: vec![std::f64::consts::FRAC_PI_6, -std::f64::consts::FRAC_PI_6],
                fillet_radius_m: 0.002,
            },
        ),
        (
            "clothoid",
            PathSpec::Clothoid {
                start: origin,
                heading_rad: 0.3,
                knots: vec![
                    CurvatureKnot {
                        s_m: 0.0,
                        curvature_per_m: -5.0,
                    },
                    CurvatureKnot {
                        s_m: 0.07,
                        curvature_per_m: 10.0,
                    },
                    CurvatureKnot {
                        s_m: 0.14,
                        curvature_per_m: -10.0,
                    },
                    CurvatureKnot {
                        s_m: 0.21,
                        curvature_per_m: 0.0,
                    },
                ],
                step_m: None,
            },
        ),
        (
            "arc, reversed (transformed)",
            PathSpec::Transformed {
                path: Box::new(PathSpec::Arc {
                    radius_m: 0.145,
                    length_m: 0.26,
                    chord_centre: SurfacePoint::new(0.0, 0.0272),
                    turn: Turn::Left,
                }),
                rotation_rad: 0.0,
                translation: SurfacePoint::new(0.0, 0.0),
                reverse: true,
            },
        ),
    ]
}

/// seed-arc-145's rig on `path`, placed 10 and 20 mm along it, tracking to 25 mm from its end.
fn on_rig(base: &Scene, name: &str, path: PathSpec) -> Result<Scene, String> {
    let p = ArteryPath::from_spec(&path).map_err(|e| format!("{name}: {e}"))?;
    let mut s = base.clone();
    s.name = name.to_string();
    s.artery.path = path;
    s.lumps.clear();
    s.placements = [p.at(0.01).0, p.at(0.02).0];
    s.start = Some(p.at(0.0).0);
    s.track = TrackSpec {
        length_m: p.length_m() - 0.035,
        reason: "speed benchmark".into(),
    };
    Ok(s)
}

/// This thread's CPU time, s (Linux's schedstat, in ns); wall time where it is unreadable.
fn cpu_s(wall: Instant) -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|t| t.split_whitespace().next()?.parse::<f64>().ok())
        .map_or_else(|| wall.elapsed().as_secs_f64(), |ns| ns * 1e-9)
}

/// Nanoseconds per query of `f` over points within 20 mm of the path.
fn per_query_ns(path: &ArteryPath, f: impl Fn(SurfacePoint) -> f64) -> f64 {
    let queries: Vec<SurfacePoint> = (0..20_000)
        .map(|i| {
            let (p, h) = path.at(path.length_m() * (i as f64 * 0.618_034).fract());
            let o = 0.02 * ((i as f64 * 0.414_214).fract() * 2.0 - 1.0);
            SurfacePoint::new(p.x_m - o * h.sin(), p.z_m + o * h.cos())
        })
        .collect();
    let t0 = Instant::now();
    let mut sink = 0.0;
    for _ in 0..5 {
        for &q in &queries {
            sink += f(q);
        }
    }
    let ns = t0.elapsed().as_secs_f64() * 1e9 / (5.0 * queries.len() as f64);
    std::hint::black_box(sink);
    ns
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args
        .iter()
        .position(|a| a == "--seeds")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let (name, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(name, text).map_err(|e| e.to_string())?;
    let base = scene::load("seed-arc-145", None).map_err(|e| e.to_string())?;
    let mut rows = vec![("arc (seed-arc-145)".to_string(), base.clone())];
    for (label, path) in courses() {
        rows.push((label.to_string(), on_rig(&base, label, path)?));
    }
    println!(
        "{:<38} {:>7} {:>10} {:>10} {:>12} {:>10} {:>12}",
        "path", "pieces", "index ns", "scan ns", "simulated s", "cpu ms", "x real time"
    );
    for (label, s) in rows {
        let path = ArteryPath::from_spec(&s.artery.path).map_err(|e| e.to_string())?;
        let index_ns = per_query_ns(&path, |q| path.nearest(q).offset_m);
        let scan_ns = per_query_ns(&path, |q| path.nearest_by_scan(q).offset_m);
        let (mut sim, mut cpu, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for seed in 1..=seeds {
            let wall = Instant::now();
            let c0 = cpu_s(wall);
            let t = run_trial(&s, &config, "seed2002", seed).map_err(|e| e.to_string())?;
            let c = cpu_s(wall) - c0;
            sim.push(t.simulated_s);
            cpu.push(c);
            ratio.push(t.simulated_s / c);
        }
        println!(
            "{:<38} {:>7} {:>10.0} {:>10.0} {:>12.1} {:>10.1} {:>12.0}",
            label,
            path.piece_count(),
            index_ns,
            scan_ns,
            median(sim),
            median(cpu) * 1e3,
            median(ratio)
        );
    }
    Ok(())
}
