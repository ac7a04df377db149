//! `pulsetrack bound --scene FILE [--json] [--pfa P] [--pd P] [--noise-n N]
//! [--element-length-mm L]`: the weakest pulse the scene's physics lets an ideal detector
//! feel: the beats it needs to decide, and how well it then knows the artery's position
//! (docs/signal-processing.md, "The detection bound"). The two sensor overrides ask how the
//! bound moves with another array (quieter elements, longer ones along the artery).

use std::path::PathBuf;
use std::process::ExitCode;

use sim::detection_bound::{BoundOptions, SceneBound, scene_bound};

use crate::cli::sim::load_config;
use crate::cli::stdout::outln;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// A shipped scene by name (`weak-pulse-3kpa.ron`) or a scene file.
    #[arg(long)]
    pub scene: String,
    /// False-alarm rate per decision.
    #[arg(long, default_value_t = 0.01)]
    pub pfa: f64,
    /// Detection probability.
    #[arg(long, default_value_t = 0.9)]
    pub pd: f64,
    /// Seeds the pump's beat-to-beat variability and the threshold's noise draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Element noise SD, N, in place of the scene's `sensor.noise_sd_n`.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub noise_n: Option<f64>,
    /// Each element's length along the artery, mm, in place of the scene's (its
    /// `sensor.element_area_m2` over the pitch); the element noise stays as given.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub element_length_mm: Option<f64>,
    /// Print one JSON document on stdout (SI units) instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// The daemon configuration giving the sensor's sample rate; default: the shipped
    /// simulator configuration.
    #[arg(long)]
    pub config: Option<PathBuf>,
}

pub fn run(args: &Args) -> ExitCode {
    match run_inner(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => crate::cli::failure::failed("bound", args.json, &message),
    }
}

fn run_inner(args: &Args) -> Result<(), String> {
    let config = load_config(args.config.as_deref())?;
    let mut scene = sim::scene::load(&args.scene, None).map_err(|e| e.to_string())?;
    override_sensor(&mut scene.sensor, args)?;
    let options = BoundOptions {
        pfa: args.pfa,
        pd: args.pd,
        seed: args.seed,
    };
    let bound = scene_bound(&scene, &config, options).map_err(|e| e.to_string())?;
    if args.json {
        let text = serde_json::to_string_pretty(&bound).map_err(|e| e.to_string())?;
        outln!("{text}");
    } else {
        print_summary(&bound);
    }
    Ok(())
}

/// Apply `--noise-n` and `--element-length-mm`, refusing what the simulator could not model.
fn override_sensor(sensor: &mut sim::scene::SensorSpec, args: &Args) -> Result<(), String> {
    if let Some(n) = args.noise_n {
        // The scene allows 0 (a noiseless sensor); a bound needs some noise.
        if !(n.is_finite() && n > 0.0 && n <= 10.0) {
            return Err(format!(
                "--noise-n must be an element noise SD in newtons, above 0 and at most 10, got {n}"
            ));
        }
        sensor.noise_sd_n = n;
    }
    if let Some(mm) = args.element_length_mm {
        let length_m = mm * 1e-3;
        // The elements lie on the bottom of the sensor's cylinder, whose diameter runs
        // along the artery; the scene's own limits on an element's area hold too.
        let most_m = sensor.body_diameter_m.min(1e-3 / sensor.pitch_m);
        let least_m = 1e-8 / sensor.pitch_m;
        if !(length_m.is_finite() && length_m >= least_m && length_m <= most_m) {
            return Err(format!(
                "--element-length-mm must be from {:.3} to {:.1} mm (the sensor body's diameter), got {mm}",
                least_m * 1e3,
                most_m * 1e3
            ));
        }
        sensor.element_area_m2 = length_m * sensor.pitch_m;
    }
    Ok(())
}

fn print_summary(b: &SceneBound) {
    outln!(
        "{}: element noise {:.1} mN at {:.0} Hz, elements {:.1} mm along the artery, heart period {:.2} s; deciding at a false-alarm rate of {} with probability {}",
        b.scene,
        b.noise_sd_n * 1e3,
        b.sample_rate_hz,
        b.element_length_m * 1e3,
        b.mean_period_s,
        b.pfa,
        b.pd
    );
    outln!(
        "thresholds: {:.2} with the artery's place known, {:.2} searched over the array ({} noise draws)",
        b.threshold_known_position,
        b.threshold_unknown_position,
        b.threshold_draws
    );
    outln!(
        "artery at   largest pulse   SNR/beat   beats known   beats searched   seconds   beats to SNR 8   position SD"
    );
    for p in &b.positions {
        outln!(
            "{:6.1} mm   {:9.2} mN   {:8.3}   {:11.1}   {:14.1}   {:7.1}   {:14.1}   {:8.3} mm",
            p.offset_m * 1e3,
            p.peak_element_pulse_n * 1e3,
            p.snr_per_beat,
            p.beats_known_position,
            p.beats_unknown_position,
            p.seconds_unknown_position,
            p.beats_to_snr_8,
            p.position_sd_m * 1e3
        );
    }
}
