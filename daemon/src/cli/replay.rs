//! `pulsetrack replay FILE.mcap [--tracker NAME] [--json]`: feed a recorded trial to a
//! tracker offline and print the points it locates, compared with those recorded live
//! (docs/foxglove.md, "Offline replay"); `pulsetrack replay FILE.mcap --live [--speed X]`:
//! serve it on the live view instead ("Replaying a trial in the live view").

use crate::cli::stdout::outln;

use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::json;

use crate::live;
use crate::recording::recover;
use crate::recording::replay::{self, Located};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// A trial recording (`.mcap`), complete or cut short.
    pub file: PathBuf,
    /// The tracker to run (default: the one that recorded the trial).
    #[arg(long)]
    pub tracker: Option<String>,
    /// Tracker parameters and array geometry from this config file instead of the
    /// configuration recorded in the trial (needed only for recordings that hold none).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// One JSON document on stdout instead of a table.
    #[arg(long, conflicts_with = "live")]
    pub json: bool,
    /// Serve the trial on the live view (Foxglove WebSocket) instead of running a tracker:
    /// it starts when a client subscribes and ends with the recording.
    #[arg(long, conflicts_with = "tracker")]
    pub live: bool,
    /// With --live: times real time.
    #[arg(long, default_value_t = 1.0, requires = "live")]
    pub speed: f64,
    /// With --live: the port (default: the configuration's live.port; 0 takes any free one).
    #[arg(long, requires = "live")]
    pub port: Option<u16>,
}

pub fn run(args: &Args) -> ExitCode {
    match run_inner(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => crate::cli::failure::failed("replay", args.json, &e),
    }
}

fn run_inner(args: &Args) -> Result<(), String> {
    if args.live {
        return run_live(args);
    }
    let back = recover::read(&args.file).map_err(|e| e.to_string())?;
    let mut rec = replay::recorded(&back).map_err(|e| format!("{}: {e}", args.file.display()))?;
    let fallback = crate::pulsetrackd::LoadedConfig::load(args.config.as_deref())
        .map_err(|e| e.to_string())?;
    let config_source = if args.config.is_some() {
        rec.config = None;
        fallback.origin.clone()
    } else if rec.config.is_some() {
        "the configuration recorded in the trial".to_string()
    } else {
        format!("{} (the trial recorded none)", fallback.origin)
    };
    let name = args
        .tracker
        .clone()
        .or_else(|| rec.tracker.clone())
        .ok_or("the recording does not name its tracker: give --tracker")?;
    let out = replay::replay_with(&rec, &name, &fallback.config)?;
    let same_tracker = rec.tracker.as_deref() == Some(name.as_str());
    let difference = replay::first_difference(&out.located, &rec.located);
    if args.json {
        let doc = json!({
            "recording": args.file,
            "tracker": name,
            "recorded_tracker": rec.tracker,
            "parameters_from": config_source,
            "frames": out.frames,
            "missing_frames": rec.missing_frames,
            "located": out.located,
            "recorded_located": rec.located,
            "identical_to_recorded": difference.is_none(),
            "first_difference": difference,
            "events": out.events,
            "refused_calls": out.refused,
        });
        outln!("{doc}");
        return Ok(());
    }
    outln!(
        "{}: {} frames replayed through {name} (recorded with {}), parameters from {config_source}",
        args.file.display(),
        out.frames,
        rec.tracker.as_deref().unwrap_or("an unnamed tracker")
    );
    if rec.missing_frames > 0 {
        outln!(
            "warning: {} frames are missing from the recording; the replay may differ from the trial",
            rec.missing_frames
        );
    }
    outln!(
        "{:>3}  {:>10}  {:>9}  {:>9}  {:>7}  {:>11}  seed",
        "#",
        "t (s)",
        "x (mm)",
        "z (mm)",
        "element",
        "amp (mN)"
    );
    for (i, p) in out.located.iter().enumerate() {
        outln!("{}", row(i, p));
    }
    for r in &out.refused {
        outln!("refused: {r}");
    }
    match (difference, same_tracker) {
        (None, _) => outln!(
            "{} located points, identical bit for bit to the {} recorded",
            out.located.len(),
            rec.located.len()
        ),
        (Some(i), true) => outln!(
            "differs from the recording at located point #{i} ({} replayed, {} recorded): the same tracker should reproduce the trial exactly",
            out.located.len(),
            rec.located.len()
        ),
        (Some(_), false) => outln!(
            "{} located points; the recording's tracker located {}",
            out.located.len(),
            rec.located.len()
        ),
    }
    Ok(())
}

fn row(i: usize, p: &Located) -> String {
    format!(
        "{i:>3}  {:>10.3}  {:>9.2}  {:>9.2}  {:>7.2}  {:>11.2}  {}",
        p.t_s,
        p.x_m * 1e3,
        p.z_m * 1e3,
        p.element,
        p.amplitude_n * 1e3,
        if p.seed { "yes" } else { "" }
    )
}

/// Serve the trial on the live view, from the first subscription to its end.
fn run_live(args: &Args) -> Result<(), String> {
    if !(args.speed.is_finite() && (0.01..=1000.0).contains(&args.speed)) {
        return Err(format!("--speed {} must be in 0.01..1000", args.speed));
    }
    let back = recover::read(&args.file).map_err(|e| e.to_string())?;
    let loaded = crate::pulsetrackd::LoadedConfig::load(args.config.as_deref())
        .map_err(|e| e.to_string())?;
    let epoch = live::replay::epoch_of(&back).ok_or_else(|| {
        format!(
            "{}: no tactile frame with a time: nothing to replay",
            args.file.display()
        )
    })?;
    let mut settings = live::server::LiveSettings::from_config(&loaded.config, epoch)
        .map_err(|e| e.to_string())?;
    settings.name = format!("pulsetrack replay {}", args.file.display());
    if let Some(p) = args.port {
        settings.port = p;
    }
    let (server, tap) = live::server::LiveServer::start(&settings).map_err(|e| e.to_string())?;
    let schedule = live::replay::schedule(&back);
    outln!(
        "{}: {} messages; open {} in Foxglove (layout: docs/foxglove/pulsetrack-layout.json); the replay starts when a client subscribes",
        args.file.display(),
        schedule.len(),
        server.url()
    );
    while !tap.anyone_subscribed() {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    // The rest of a client's subscriptions follow its first within moments.
    std::thread::sleep(std::time::Duration::from_millis(500));
    outln!("replaying at {}x real time", args.speed);
    let report = live::replay::serve(&schedule, &tap, args.speed);
    drop(tap);
    // Let the publisher empty its queue and the clients their backlogs before closing.
    std::thread::sleep(std::time::Duration::from_millis(500));
    server.stop();
    outln!(
        "replayed {} messages over {:.1} s of recording{}",
        report.messages,
        report.span_s,
        if report.skipped.is_empty() {
            String::new()
        } else {
            format!("; not on the live view: {:?}", report.skipped)
        }
    );
    Ok(())
}
