//! `pulsetrack sim --scene FILE [--tracker NAME] [--trials N] [--seed S] [--json] [--plot DIR]
//! [--calibration FILE]`:
//! run whole trials on the simulated bench in lockstep (no clock, no threads) and report
//! what the tracker located against the true artery.
//!
//! With `--json` stdout is one JSON document (docs/sim-json.md); otherwise a human summary.
//! Progress and diagnostics go to stderr only.

use crate::cli::stdout::outln;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use config::Config;
use control::signal::bandpass::{BandPass, BandPassSpec};
use control::types::ELEMENTS;
use serde::Serialize;
use sim::scene::{ArteryPath, Scene};
use sim::trial::{TrialResult, TrialsSummary};
use sim::trial_event::TrialEvent;

use crate::plot::{Chart, Hue, Mark, Series, write_chart};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// A shipped scene by name (`seed-arc-145.ron`) or a scene file.
    #[arg(long)]
    pub scene: String,
    /// The tracker to run.
    #[arg(long, default_value = "seed2002")]
    pub tracker: String,
    /// Trials to run; trial i uses seed S + i.
    #[arg(long, default_value_t = 1)]
    pub trials: u32,
    /// Random seed of the first trial.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print one JSON document on stdout instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Write plots (PNG and SVG) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// With --plot: draw the ten elements' trace as read (each about its own mean) instead
    /// of band-passed as in the seed's Fig. 2.
    #[arg(long, requires = "plot")]
    pub plot_raw: bool,
    /// Print every tracker event of every trial on stderr as JSON lines (one object each:
    /// kind and fields, believed and true sensor positions in metres; docs/sim-json.md),
    /// and each trial's end as a `trial` object, so that every stderr line is JSON.
    #[arg(long)]
    pub events: bool,
    /// With --events: lines for people (millimetres) instead of JSON.
    #[arg(long, requires = "events")]
    pub events_text: bool,
    /// The daemon configuration giving the rig's geometry, gains and tracker constants;
    /// default: the shipped simulator configuration.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// A calibration file (as `pulsetrack calibrate` writes it): its tactile calibration,
    /// tissue frame and pivot are applied to every trial as the daemon applies them. Default:
    /// none (the array, the tissue frame and the pivot as configured, whatever errors the
    /// scene gives them).
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
}

/// The calibrations in `path`'s calibration file (tactile, tissue, pivot, the joints' zero);
/// refused as the daemon would refuse them (none, one that did not pass, or a tactile one
/// leaving too few elements with `sensor`'s skipped).
fn file_calibration(
    path: &Path,
    sensor: &control::sensor::ArrayGeometry,
) -> Result<sim::runner::Calibrated, String> {
    let file = config::calibration_file::load(path)
        .map_err(|e| e.to_string())?
        .ok_or_else(|| format!("{}: no such file", path.display()))?
        .value;
    if file.tactile.is_none()
        && file.tissue.is_none()
        && file.pivot.is_none()
        && file.joints.is_none()
    {
        return Err(format!("{}: holds no calibration", path.display()));
    }
    // The daemon's own tests of a record it may use.
    let tactile = match file.tactile {
        Some(r) => Some(
            crate::supervisor::calibration::usable_record(&r, sensor)
                .map(|_| r.calibration)
                .map_err(|e| format!("{}: {e}", path.display()))?,
        ),
        None => None,
    };
    let tissue = file
        .tissue
        .map(|r| crate::supervisor::calibration::usable_tissue(&r))
        .transpose()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let pivot_in_base_m = file
        .pivot
        .map(|r| crate::supervisor::calibration::usable_pivot(&r))
        .transpose()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let joint_zero_rad = file
        .joints
        .map(|r| crate::supervisor::calibration::usable_joints(&r))
        .transpose()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(sim::runner::Calibrated {
        tactile,
        tissue,
        pivot_in_base_m,
        joint_zero_rad,
    })
}

#[derive(Debug, Serialize)]
struct Report<'a> {
    scene: &'a str,
    tracker: &'a str,
    trials: &'a [TrialResult],
}

pub fn run(args: &Args) -> ExitCode {
    match run_inner(args) {
        Ok(code) => code,
        Err(message) => crate::cli::failure::failed("sim", args.json, &message),
    }
}

/// The config named on the command line, else the embedded sim default (`sim` and `bench`).
pub(crate) fn load_config(path: Option<&Path>) -> Result<Config, String> {
    match path {
        Some(p) => config::load_file::<Config>(p)
            .map(|l| l.value)
            .map_err(|e| e.to_string()),
        None => {
            let (name, text) = config::shipped::SIM_CONFIG;
            config::load_str::<Config>(&format!("<shipped {name}>"), text)
                .map_err(|e| e.to_string())
        }
    }
}

fn run_inner(args: &Args) -> Result<ExitCode, String> {
    if args.trials == 0 {
        return Err("--trials must be at least 1".into());
    }
    let config = load_config(args.config.as_deref())?;
    let scene = sim::scene::load(&args.scene, None).map_err(|e| e.to_string())?;
    let calibration = args
        .calibration
        .as_deref()
        .map(|p| file_calibration(p, &config.sensor))
        .transpose()?
        .unwrap_or_default();
    let mut trials = Vec::with_capacity(args.trials as usize);
    for i in 0..args.trials {
        let seed = args.seed.wrapping_add(i as u64);
        let trial =
            sim::runner::run_trial_calibrated(&scene, &config, &args.tracker, seed, &calibration)
                .map_err(|e| e.to_string())?;
        if args.events && !args.events_text {
            for event in &trial.log {
                eprintln!("{}", event_line(i + 1, seed, event)?);
            }
            eprintln!("{}", trial_line(i + 1, &trial)?);
            trials.push(trial);
            continue;
        }
        eprintln!(
            "trial {}/{} (seed {seed}): {} after {:.0} s simulated, {} points, lateral error SD {:.2} mm, {} backtracks, {:.2} s wall",
            i + 1,
            args.trials,
            trial.end_reason,
            trial.duration_s,
            trial.located.len(),
            trial.lateral_error_m.sd * 1e3,
            trial.backtracks,
            trial.wall_s
        );
        if args.events_text {
            for event in &trial.log {
                eprintln!("  {}", event.describe());
            }
        }
        trials.push(trial);
    }
    // The results first: a chart that cannot be drawn must not lose them.
    let plotted = args.plot.as_ref().map(|dir| {
        let path = ArteryPath::from_spec(&scene.artery.path).map_err(|e| e.to_string())?;
        let trace = if args.plot_raw {
            Trace::Raw
        } else {
            Trace::BandPassed
        };
        plot_trials(&config, &scene, &args.tracker, &path, &trials, dir, trace)
            .map_err(|e| e.to_string())
    });
    if args.json {
        let report = Report {
            scene: &scene.name,
            tracker: &args.tracker,
            trials: &trials,
        };
        let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        outln!("{text}");
    } else {
        print_summary(&scene, &args.tracker, &trials);
    }
    if let Some(plotted) = plotted {
        let plotted = plotted?;
        for note in &plotted.notes {
            eprintln!("plot: {note}");
        }
        for f in &plotted.files {
            eprintln!("wrote {}", f.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// One event as a JSON line, tagged with its trial (1-based) and the trial's seed.
fn event_line(trial: u32, seed: u64, event: &TrialEvent) -> Result<String, String> {
    let mut v = serde_json::to_value(event).map_err(|e| e.to_string())?;
    if let Some(o) = v.as_object_mut() {
        o.insert("trial".into(), trial.into());
        o.insert("trial_seed".into(), seed.into());
    }
    Ok(v.to_string())
}

/// A trial's end as a JSON line (`kind: "trial"`), after its events.
fn trial_line(trial: u32, t: &TrialResult) -> Result<String, String> {
    Ok(serde_json::json!({
        "kind": "trial",
        "trial": trial,
        "trial_seed": t.seed,
        "end_reason": t.end_reason,
        "completed": t.completed,
        "points": t.located.len(),
        "lateral_error_sd_m": t.lateral_error_m.sd,
        "backtracks": t.backtracks,
        "duration_s": t.duration_s,
        "wall_s": t.wall_s,
    })
    .to_string())
}

fn print_summary(scene: &Scene, tracker: &str, trials: &[TrialResult]) {
    outln!("scene {} with tracker {tracker}", scene.name);
    outln!(
        "{:>5} {:>8} {:>16} {:>7} {:>9} {:>9} {:>9} {:>9} {:>6} {:>6} {:>9} {:>7}",
        "trial",
        "seed",
        "end",
        "points",
        "mean mm",
        "sd mm",
        "p95 mm",
        "max mm",
        "false",
        "back",
        "track s",
        "wall s"
    );
    for (i, t) in trials.iter().enumerate() {
        outln!(
            "{:>5} {:>8} {:>16} {:>7} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>6} {:>6} {:>9.1} {:>7.3}",
            i + 1,
            t.seed,
            t.end_reason,
            t.lateral_error_m.points,
            t.lateral_error_m.mean * 1e3,
            t.lateral_error_m.sd * 1e3,
            t.lateral_error_m.p95 * 1e3,
            t.lateral_error_m.max * 1e3,
            t.false_points,
            t.backtracks,
            t.duration_s,
            t.wall_s
        );
    }
    let s = TrialsSummary::of(trials);
    outln!(
        "all: {}/{} completed, pooled lateral error {:.2} ± {:.2} mm (mean ± SD), {:.2} backtracks per trial, {:.0} s per track",
        s.completed,
        s.trials,
        s.pooled_mean_m * 1e3,
        s.pooled_sd_m * 1e3,
        s.backtracks_per_trial,
        s.mean_duration_s
    );
}

/// The charts written, and what could not be drawn and why.
#[derive(Debug, Default)]
struct Plotted {
    files: Vec<PathBuf>,
    notes: Vec<String>,
}

/// A trial's legend entry: a trial that located nothing is shown as such.
fn trial_label(i: usize, t: &TrialResult) -> String {
    if t.located.is_empty() {
        format!(
            "trial {} (seed {}): never seeded ({}), nothing located",
            i + 1,
            t.seed,
            t.end_reason
        )
    } else {
        format!("trial {} (seed {})", i + 1, t.seed)
    }
}

/// What a chart shows: scene, tracker and the trials' seeds, for its title.
fn figure_of(scene: &Scene, tracker: &str, trials: &[TrialResult]) -> String {
    let seeds = match (trials.first(), trials.last()) {
        (Some(a), Some(b)) if trials.len() > 1 => format!("seeds {}-{}", a.seed, b.seed),
        (Some(a), _) => format!("seed {}", a.seed),
        _ => "no trial".to_string(),
    };
    format!("{}, {tracker}, {seeds}", scene.name)
}

/// How the ten elements' trace is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Trace {
    /// Band-passed with the seed's filter as the tracker configures it (the seed's Fig. 2).
    BandPassed,
    /// As read, each element about its own mean over the window.
    Raw,
}

fn plot_trials(
    config: &Config,
    scene: &Scene,
    tracker: &str,
    path: &ArteryPath,
    trials: &[TrialResult],
    dir: &Path,
    trace_kind: Trace,
) -> Result<Plotted, crate::plot::PlotError> {
    let mm = |v: f64| v * 1e3;
    let figure = figure_of(scene, tracker, trials);
    let mut files = Vec::new();
    let mut notes = Vec::new();
    for (i, t) in trials.iter().enumerate() {
        if t.located.is_empty() {
            notes.push(format!(
                "trial {} (seed {}): the tracker never seeded ({}); it located no point to plot",
                i + 1,
                t.seed,
                t.end_reason
            ));
        }
    }
    // Top view: the true path, every trial's located points, and where the sensor truly was.
    let mut top = Chart::new(
        format!("{figure}: located points, top view"),
        "x (mm)",
        "z (mm)",
    )
    .with(
        Series::new(
            "true artery",
            path.sample(0.001)
                .iter()
                .map(|p| (mm(p.x_m), mm(p.z_m)))
                .collect(),
            Mark::Line,
        )
        .hue(Hue::Truth),
    );
    top.equal_aspect = true;
    for (i, t) in trials.iter().enumerate() {
        top = top.with(
            Series::new(
                trial_label(i, t),
                t.located.iter().map(|p| (mm(p.x_m), mm(p.z_m))).collect(),
                Mark::LinePoints,
            )
            .hue(Hue::Index(i)),
        );
    }
    let false_points: Vec<&sim::trial::LocatedSample> = trials
        .iter()
        .flat_map(|t| &t.located)
        .filter(|p| p.lateral_error_m.abs() > sim::trial::FALSE_POINT_M)
        .collect();
    let false_label = format!(
        "false points (> {:.0} mm off): {}",
        sim::trial::FALSE_POINT_M * 1e3,
        false_points.len()
    );
    if !false_points.is_empty() {
        top = top.with(Series::new(
            false_label.clone(),
            false_points
                .iter()
                .map(|p| (mm(p.x_m), mm(p.z_m)))
                .collect(),
            Mark::Crosses,
        ));
    }
    files.extend(write_chart(&top, dir, "top_view")?);
    // Lateral error against distance along the path.
    let mut err = Chart::new(
        format!("{figure}: lateral error of located points"),
        "distance along the path (mm)",
        "signed lateral error (mm)",
    );
    for (i, t) in trials.iter().enumerate() {
        err = err.with(
            Series::new(
                trial_label(i, t),
                t.located
                    .iter()
                    .map(|p| (mm(p.along_path_m), mm(p.lateral_error_m)))
                    .collect(),
                Mark::LinePoints,
            )
            .hue(Hue::Index(i)),
        );
    }
    if !false_points.is_empty() {
        err = err.with(Series::new(
            false_label,
            false_points
                .iter()
                .map(|p| (mm(p.along_path_m), mm(p.lateral_error_m)))
                .collect(),
            Mark::Crosses,
        ));
    }
    if trials.iter().all(|t| t.located.is_empty()) {
        notes.push("error_along_path not drawn: no trial located a point".into());
    } else {
        files.extend(write_chart(&err, dir, "error_along_path")?);
    }
    // A 4 s trace of all ten elements at the first placement, band-passed with the seed's
    // filter as the tracker configures it (the seed's Fig. 2).
    if let Some(t) = trials.first()
        && let Some(first) = t.first_acquisition.first()
    {
        let t0 = first.t_s;
        let window: Vec<_> = t
            .first_acquisition
            .iter()
            .filter(|f| f.t_s - t0 <= 4.0)
            .collect();
        let p = &config.tracker.params.seed2002;
        let filter = match trace_kind {
            Trace::BandPassed => BandPass::design(BandPassSpec {
                order: p.fir_order,
                low_hz: p.band_low_hz,
                high_hz: p.band_high_hz,
                sample_rate_hz: config.sensor.sample_rate_hz,
            })
            .map_err(|e| e.to_string()),
            Trace::Raw => Err("raw requested".to_string()),
        };
        let (how, axis) = match (trace_kind, &filter) {
            (Trace::BandPassed, Ok(_)) => ("band-passed", "filtered force (N)"),
            _ => (
                "as read, about each element's mean",
                "force about its mean (N)",
            ),
        };
        let mut trace = Chart::new(
            format!(
                "{}, {tracker}, seed {}: the ten elements at the first placement, 4 s, {how}",
                scene.name, t.seed
            ),
            "time (s)",
            axis,
        );
        for e in 0..ELEMENTS {
            let raw: Vec<f64> = window.iter().map(|f| f.force_n[e]).collect();
            let mut filtered = vec![0.0; raw.len()];
            match &filter {
                Ok(bp) => bp.apply(&raw, &mut filtered),
                Err(_) => {
                    // No usable filter in the configuration: plot the raw force about its mean.
                    let mean = raw.iter().sum::<f64>() / raw.len().max(1) as f64;
                    for (o, r) in filtered.iter_mut().zip(&raw) {
                        *o = r - mean;
                    }
                }
            }
            trace = trace.with(Series::new(
                format!("element {e}"),
                window
                    .iter()
                    .zip(&filtered)
                    .map(|(f, v)| (f.t_s - t0, *v))
                    .collect(),
                Mark::Line,
            ));
        }
        files.extend(write_chart(&trace, dir, "elements_4s")?);
    }
    Ok(Plotted { files, notes })
}
