//! Issue 18's goal benchmark for the weak-pulse detector alone, on simulated scenes: marks
//! at rest on internal-mammary-like arteries (`config/families/detection/ima.ron`), each
//! against the detection bound of its own scene, and the same windows with no pulse (noise
//! only) and with a lump under the array instead (lump only).
//!
//! Each pulse trial draws a scene, holds the ideal arm at its first placement moved across
//! the artery by up to ±4 mm, feeds the frames to `control::signal::weak_pulse` until it
//! decides or reaches its limit, and compares the beats it took with the position-searched
//! bound's for that scene and place (`pulsetrack_sim::detection_bound`, same false-alarm
//! rate, detection probability 0.9). The threshold is the detector's own noise law,
//! measured here on unit normals. The tracker's marks do not use the detector yet: this is
//! where it stands before that.
//!
//! `cargo run --release -p pulsetrack-sim --example weak_marks -- [TRIALS] [SEED] [PFA] [LIMIT_S] [DRAWS] [SEGMENT_S] [FAMILY]`
//! (defaults 60, 1, 0.01, 600, 1000, the detector's coherent segment and the IMA family:
//! about 8 minutes, most of it the noise law).

use control::frames::SurfacePoint;
use control::signal::weak_pulse::{
    Decision, NoiseLaw, PulseShape, WeakPulseDetector, WeakPulseSettings,
};
use pulsetrack_sim::bench::Bench;
use pulsetrack_sim::detection_bound::{BoundOptions, scene_bound};
use pulsetrack_sim::family;
use pulsetrack_sim::random::{Stream, standard_normal, stream, uniform_open};
use pulsetrack_sim::scene::{LumpSpec, PulseSpec, Scene};

/// The family drawn unless a seventh argument names another.
const FAMILY: &str = "config/families/detection/ima.ron";
/// The spatial template's width, m: the family's middle depth (5-8 mm), as a user would set
/// it from the depth expected (the detector's default, 5 mm, is the seed's tube).
const KERNEL_WIDTH_M: f64 = 0.0065;
/// Largest offset of the artery from the array's centre, m.
const MAX_OFFSET_M: f64 = 0.004;

struct Outcome {
    found: bool,
    beats: f64,
    offset_error_m: f64,
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: f64| -> Result<f64, String> {
        args.get(i).map_or(Ok(default), |s| {
            s.parse::<f64>()
                .map_err(|e| format!("argument {}: {s}: {e}", i + 1))
        })
    };
    let trials = arg(0, 60.0)? as u64;
    let seed = arg(1, 1.0)? as u64;
    let pfa = arg(2, 0.01)?;
    let limit_s = arg(3, 600.0)?;
    let draws = arg(4, 1000.0)? as usize;
    let segment_s = arg(5, WeakPulseSettings::default().segment_s)?;

    let (cname, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(cname, text).map_err(|e| e.to_string())?;
    let family_path = args.get(6).map_or(FAMILY, String::as_str);
    let fam = family::load(family_path, None).map_err(|e| e.to_string())?;
    let settings = WeakPulseSettings {
        geometry: config.sensor,
        kernel_width_m: KERNEL_WIDTH_M,
        limit_s,
        segment_s,
        ..WeakPulseSettings::default()
    };
    let shape = PulseShape::Generic;
    eprintln!("measuring the noise law: {draws} draws of {limit_s} s");
    let mut rng = stream(seed ^ 0x5eed, Stream::SensorNoise);
    let law = NoiseLaw::measure(&settings, &shape, draws, &mut || standard_normal(&mut rng))
        .map_err(|e| e.to_string())?;
    let threshold = law.threshold(pfa, limit_s).map_err(|e| e.to_string())?;
    println!(
        "threshold: log ratio {:.2} for a false-alarm rate of {pfa} over {limit_s} s ({draws} draws)",
        threshold.log_ratio
    );

    let mut ratios = Vec::new();
    let mut errors = Vec::new();
    let (mut found, mut within_2x, mut within_1mm) = (0usize, 0usize, 0usize);
    println!("trial  offset mm  bound beats  decided  beats  beats/bound  error mm");
    for k in 0..trials {
        let trial_seed = seed.wrapping_mul(1000).wrapping_add(k);
        let scene = fam.draw(trial_seed)?;
        let mut offset_rng = stream(trial_seed, Stream::Faults);
        let offset = MAX_OFFSET_M * (2.0 * uniform_open(&mut offset_rng) - 1.0);
        let bound = scene_bound(
            &scene,
            &config,
            BoundOptions {
                pfa,
                pd: 0.9,
                seed: trial_seed,
            },
        )
        .map_err(|e| e.to_string())?;
        let bound_beats = bound
            .positions
            .iter()
            .min_by(|a, b| {
                (a.offset_m - offset.abs())
                    .abs()
                    .total_cmp(&(b.offset_m - offset.abs()).abs())
            })
            .map_or(f64::NAN, |p| p.beats_unknown_position);
        let o = run_mark(
            &scene, &config, &settings, &shape, &threshold, offset, trial_seed,
        )?;
        if o.found {
            found += 1;
            let ratio = o.beats / bound_beats;
            ratios.push(ratio);
            within_2x += usize::from(ratio <= 2.0);
            within_1mm += usize::from(o.offset_error_m.abs() <= 1e-3);
            errors.push(o.offset_error_m);
        }
        println!(
            "{k:5}  {:9.2}  {bound_beats:11.1}  {:>7}  {:5.1}  {:11.2}  {:8}",
            offset * 1e3,
            if o.found { "found" } else { "no" },
            o.beats,
            o.beats / bound_beats,
            if o.found {
                format!("{:.2}", o.offset_error_m * 1e3)
            } else {
                "-".into()
            }
        );
    }
    let mut false_noise = 0usize;
    let mut false_lump = 0usize;
    for k in 0..trials {
        let trial_seed = seed.wrapping_mul(1000).wrapping_add(10_000 + k);
        let mut scene = fam.draw(trial_seed)?;
        scene.pulse = PulseSpec::Absent;
        let o = run_mark(
            &scene, &config, &settings, &shape, &threshold, 0.0, trial_seed,
        )?;
        false_noise += usize::from(o.found);
        // A stiff lump 3-6 mm beside the array's centre, under a still pulse-free artery.
        let mut rng = stream(trial_seed, Stream::Faults);
        let at = scene.placements[0];
        let side = 0.003 + 0.003 * uniform_open(&mut rng);
        scene.lumps = vec![LumpSpec {
            centre: SurfacePoint::new(at.x_m, at.z_m + side),
            depth_m: 0.004 + 0.004 * uniform_open(&mut rng),
            pressure_gain: 0.2 + 0.6 * uniform_open(&mut rng),
        }];
        let o = run_mark(
            &scene, &config, &settings, &shape, &threshold, 0.0, trial_seed,
        )?;
        false_lump += usize::from(o.found);
    }
    ratios.sort_by(f64::total_cmp);
    let q = |p: f64| {
        ratios
            .get(((ratios.len() as f64 - 1.0) * p).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    let n = trials as f64;
    println!(
        "found {found}/{trials} ({:.1} %); decided within 2x the bound's beats {within_2x} ({:.1} %); \
         beats / bound's among found: 10 % {:.2}, median {:.2}, 90 % {:.2}; \
         position error RMS {:.2} mm, within 1 mm {within_1mm} of {found}; \
         false found: noise only {false_noise}/{trials} ({:.1} %), lump only {false_lump}/{trials} ({:.1} %)",
        100.0 * found as f64 / n,
        100.0 * within_2x as f64 / n,
        q(0.1),
        q(0.5),
        q(0.9),
        rms * 1e3,
        100.0 * false_noise as f64 / n,
        100.0 * false_lump as f64 / n,
    );
    Ok(())
}

/// Hold the ideal arm at the scene's first placement moved `offset_m` across the course
/// (so the artery lies `-offset_m` from the array's centre) and run the detector.
fn run_mark(
    scene: &Scene,
    config: &config::Config,
    settings: &WeakPulseSettings,
    shape: &PulseShape,
    threshold: &control::signal::weak_pulse::Threshold,
    offset_m: f64,
    seed: u64,
) -> Result<Outcome, String> {
    let mut bench = Bench::new(scene, config, seed, true).map_err(|e| e.to_string())?;
    let at = scene.placements[0];
    bench.place_ideal(SurfacePoint::new(at.x_m, at.z_m + offset_m));
    let mut detector = WeakPulseDetector::new(settings.clone(), shape.clone(), threshold)
        .map_err(|e| e.to_string())?;
    loop {
        let Some(frame) = bench.step() else {
            continue;
        };
        detector.push(&frame).map_err(|e| e.to_string())?;
        match detector.decision() {
            Some(Decision::Found(f)) => {
                return Ok(Outcome {
                    found: true,
                    beats: f.beats,
                    offset_error_m: f.offset_z_m - (-offset_m),
                });
            }
            Some(Decision::NotFound { .. }) => {
                return Ok(Outcome {
                    found: false,
                    beats: f64::NAN,
                    offset_error_m: f64::NAN,
                });
            }
            None => {}
        }
    }
}
