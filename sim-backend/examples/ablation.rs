//! The calibration's ablation: each candidate mechanism for the seed's errors switched on
//! alone (and some together) on the shipped seed scenes, `seed2002`, trials with seeds
//! `1..=N`; and the radial wrist under each pressure model. docs/calibration.md quotes it.
//!
//! `cargo run --release -p pulsetrack-sim --example ablation -- [TRIALS] [arcs|wrist]`

use pulsetrack_fem::kernel::FemKernelSpec;
use pulsetrack_fem::material::Material;
use pulsetrack_sim::runner::run_trial;
use pulsetrack_sim::scene::{
    self, ArteryPath, MountSpec, PinAxis, Placing, PressureKernel, PulseCoupling, PulseSpec, Scene,
};
use pulsetrack_sim::trial::TrialResult;

type Variant = (&'static str, fn(&mut Scene));

const FOAM_SCENES: [&str; 4] = [
    "seed-arc-220.ron",
    "seed-arc-145.ron",
    "seed-arc-80.ron",
    "seed-s-curve.ron",
];

fn foam_variants() -> Vec<Variant> {
    vec![
        ("shipped", |_| {}),
        ("pin along the line", |s| {
            s.sensor.mount = Some(MountSpec {
                pin: PinAxis::AlongLine,
            })
        }),
        ("pin across the line", |s| {
            s.sensor.mount = Some(MountSpec {
                pin: PinAxis::AcrossLine,
            })
        }),
        ("hold-down coupling", |s| {
            s.artery.coupling = PulseCoupling::HoldDown {
                reference_normal_n: 0.3 * 9.81,
            }
        }),
        ("incision hysteresis 0.1 N", |s| {
            if let Some(p) = &mut s.pivot {
                p.hysteresis_slip_n = Some(0.1);
            }
        }),
        ("incision hysteresis 0.3 N", |s| {
            if let Some(p) = &mut s.pivot {
                p.hysteresis_slip_n = Some(0.3);
            }
        }),
        ("foam sheet 15 mm on a table (FEM)", |s| {
            let foam = Material::new(20e3, 0.45);
            s.artery.kernel = PressureKernel::Fem(FemKernelSpec {
                tissue: foam,
                wall: foam,
                refine: 0,
                backing_gap_m: Some(0.0075),
                wall_flattened: false,
            })
        }),
        ("placed by eye", |s| s.placed_by = Placing::Eye),
        ("pin along + hold-down + hysteresis 0.1 N", |s| {
            s.sensor.mount = Some(MountSpec {
                pin: PinAxis::AlongLine,
            });
            s.artery.coupling = PulseCoupling::HoldDown {
                reference_normal_n: 0.3 * 9.81,
            };
            if let Some(p) = &mut s.pivot {
                p.hysteresis_slip_n = Some(0.1);
            }
        }),
    ]
}

fn wrist_variants() -> Vec<Variant> {
    fn fem(s: &mut Scene, flattened: bool) {
        // The FEM kernel needs a constant depth: the distal 3.4 mm.
        s.artery.depth_end_m = None;
        s.artery.kernel = PressureKernel::Fem(FemKernelSpec {
            tissue: Material::new(50e3, 0.49),
            wall: Material::new(400e3, 0.49),
            refine: 0,
            backing_gap_m: Some(0.001),
            wall_flattened: flattened,
        });
    }
    fn pulse_pressure(s: &mut Scene, mmhg: f64) {
        if let PulseSpec::Physiological {
            systolic_pa,
            diastolic_pa,
            ..
        } = &mut s.pulse
        {
            *systolic_pa = *diastolic_pa + mmhg * 133.322;
        }
    }
    vec![
        ("shipped (applanated)", |_| {}),
        ("half-space kernel", |s| {
            s.artery.kernel = PressureKernel::Analytic
        }),
        ("FEM, round wall, on bone (3.4 mm)", |s| fem(s, false)),
        ("FEM, wall flattened, on bone (3.4 mm)", |s| fem(s, true)),
        ("elements 2 x 3 mm", |s| s.sensor.element_area_m2 = 6e-6),
        ("elements 2 x 4 mm", |s| s.sensor.element_area_m2 = 8e-6),
        ("pulse pressure 60 mmHg", |s| pulse_pressure(s, 60.0)),
        ("2 x 3 mm, 60 mmHg", |s| {
            s.sensor.element_area_m2 = 6e-6;
            pulse_pressure(s, 60.0);
        }),
        ("2 x 4 mm, 60 mmHg", |s| {
            s.sensor.element_area_m2 = 8e-6;
            pulse_pressure(s, 60.0);
        }),
    ]
}

/// Error "in the z-direction" (the seed's Fig. 3 measure): from each located point to the
/// path at the same `x`, m.
fn z_error(path: &ArteryPath, x: f64, z: f64) -> Option<f64> {
    let mut s = path.nearest(control::frames::SurfacePoint::new(x, z)).s_m;
    for _ in 0..50 {
        let (p, h) = path.at(s);
        if h.cos().abs() < 0.2 {
            return None;
        }
        let dx = p.x_m - x;
        if dx.abs() < 1e-12 {
            return Some(z - p.z_m);
        }
        s -= dx / h.cos();
    }
    None
}

fn sd(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return f64::NAN;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

fn summary(scene: &Scene, trials: &[TrialResult]) -> String {
    let path = match ArteryPath::from_spec(&scene.artery.path) {
        Ok(p) => p,
        Err(e) => return format!("path: {e}"),
    };
    let points: Vec<_> = trials
        .iter()
        .flat_map(|t| t.located.iter().filter(|p| !p.seed))
        .collect();
    let normal: Vec<f64> = points.iter().map(|p| p.lateral_error_m).collect();
    let zdir: Vec<f64> = points
        .iter()
        .filter_map(|p| z_error(&path, p.x_m, p.z_m))
        .collect();
    let n = trials.len().max(1) as f64;
    let completed = trials.iter().filter(|t| t.completed).count();
    let seeded = trials
        .iter()
        .filter(|t| t.end_reason != "not_seeded")
        .count();
    let backtracks = trials.iter().map(|t| t.backtracks as f64).sum::<f64>() / n;
    let mut durations: Vec<f64> = trials
        .iter()
        .filter(|t| t.duration_s > 0.0)
        .map(|t| t.duration_s)
        .collect();
    durations.sort_by(f64::total_cmp);
    let median = durations.get(durations.len() / 2).copied().unwrap_or(0.0);
    let mut tracked: Vec<f64> = trials.iter().map(|t| t.tracked_length_m).collect();
    tracked.sort_by(f64::total_cmp);
    let tracked_mm = tracked.get(tracked.len() / 2).copied().unwrap_or(0.0) * 1e3;
    format!(
        "SD {:.2} (z {:.2}) mm, {:.2} backtracks, {}/{} done ({} seeded), {:.0} s, {:.0} mm tracked",
        sd(&normal) * 1e3,
        sd(&zdir) * 1e3,
        backtracks,
        completed,
        trials.len(),
        seeded,
        median,
        tracked_mm
    )
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let trials: u64 = match args.first() {
        Some(a) => a.parse().map_err(|e| format!("{a}: {e}"))?,
        None => 7,
    };
    let which = args.get(1).map(String::as_str).unwrap_or("arcs");
    let (cname, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(cname, text).map_err(|e| e.to_string())?;
    let (scenes, variants): (&[&str], Vec<Variant>) = match which {
        "arcs" => (&FOAM_SCENES, foam_variants()),
        "wrist" => (&["seed-radial-wrist.ron"], wrist_variants()),
        other => return Err(format!("{other}: expected arcs or wrist")),
    };
    println!("{trials} trials per scene (seeds 1..={trials}), seed2002");
    for (name, apply) in variants {
        println!("{name}");
        for file in scenes {
            let mut s = scene::load(file, None).map_err(|e| e.to_string())?;
            apply(&mut s);
            let results: Vec<TrialResult> = (1..=trials)
                .map(|seed| run_trial(&s, &config, "seed2002", seed))
                .collect::<Result<_, _>>()
                .map_err(|e| e.to_string())?;
            println!("  {:<16} {}", s.name, summary(&s, &results));
        }
    }
    Ok(())
}
