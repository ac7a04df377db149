//! `pulsetrack bench [--scenes GLOB] [--families GLOB] [--trackers LIST] [--trials N]
//! [--seed S] [--json] [--plot DIR] [--dump-scene DIR] [--config FILE]`: a Monte Carlo of
//! whole lockstep trials over scenes (or scene families) and trackers, on every core,
//! reported as speed against error.
//!
//! Every (scene, tracker, trial) is an independent job whose seed is `S + trial`: the same
//! seeds for every scene and tracker (paired comparisons), and results that do not depend
//! on which thread ran what. A family's trial `i` runs on the scene the family draws from
//! seed `S + i` (the same scene for every tracker); `--dump-scene DIR` writes each drawn
//! scene as `DIR/<family>-<seed>.ron`, which `pulsetrack sim --scene FILE --seed <seed>`
//! reruns exactly. Jobs run on rayon's pool; their results are gathered in job
//! order. Progress goes to stderr; with `--json` stdout is one document (docs/BENCHMARKS.md
//! describes its fields), otherwise a table. `--plot DIR` draws, per scene, time against
//! error for every tracker and speed setting (the speed-against-error front).
//!
//! A tracker is named as the config and `pulsetrack sim` name it, optionally with a speed
//! setting in mm/s after `@`: `beatslide@20` runs `beatslide` with its speed set to
//! 20 mm/s (`TrackerParams::set_speed`).

use crate::cli::progress::Progress;
use crate::cli::sim::load_config;
use crate::cli::stdout::outln;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use config::Config;
use rayon::prelude::*;
use serde::Serialize;
use sim::family::LoadedFamily;
use sim::scene::Scene;
use sim::trial::{LateralError, TrialResult};

use crate::plot::{Chart, Hue, Mark, Series, Spread, write_chart};

/// Path length the beat count is normalized to (the seed's 26 cm tracks), m.
const REFERENCE_LENGTH_M: f64 = 0.26;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenes: comma-separated glob patterns over the shipped scene names (`seed-arc-*`) or
    /// over files (`config/scenes/*.ron`; a pattern with a `/` matches files in that
    /// directory). Default, when no family is given either: `seed-arc-*,seed-s-curve`.
    #[arg(long)]
    pub scenes: Option<String>,
    /// Scene families, as `--scenes` names scenes (`sinusoids`, `config/families/*.ron`):
    /// each trial runs on the scene the family draws from the trial's seed.
    #[arg(long, alias = "family")]
    pub families: Option<String>,
    /// Write every scene drawn from a family into this directory as an ordinary scene file
    /// (`<family>-<seed>.ron`).
    #[arg(long)]
    pub dump_scene: Option<PathBuf>,
    /// Trackers: comma-separated names, each optionally with a speed setting in mm/s
    /// (`seed2002,beatslide@5,beatslide@10`).
    #[arg(long, default_value = "seed2002,beatslide")]
    pub trackers: String,
    /// Trials per scene and tracker; trial i uses seed S + i.
    #[arg(long, default_value_t = 7)]
    pub trials: u32,
    /// Seed of the first trial.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print one JSON document on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write the speed-against-error plots (PNG and SVG) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// The daemon configuration giving the rig and the trackers' constants; default: the
    /// shipped simulator configuration.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// What to measure: `track` (follow an artery from two placements) or `search` (find
    /// one in a region without being shown; docs/search.md).
    #[arg(long, default_value = "track", value_parser = ["track", "search"])]
    pub task: String,
    /// With `--task search`: the side of the square region, mm.
    #[arg(long, default_value_t = 40.0)]
    pub region_mm: f64,
    /// With `--task search`: the methods, comma-separated (`search`, `raster`).
    #[arg(long, default_value = "search,raster")]
    pub methods: String,
}

/// A tracker and its speed setting.
#[derive(Debug, Clone, PartialEq)]
struct TrackerSpec {
    /// As written on the command line (`beatslide@10`).
    label: String,
    name: String,
    speed_m_s: Option<f64>,
}

/// One row of the report: a scene and a tracker over all trials.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Row {
    /// The scene's name, or the family's for a row of drawn scenes.
    pub scene: String,
    /// The family the trials' scenes were drawn from (`<family>-<seed>` each); null for a
    /// fixed scene.
    pub family: Option<String>,
    /// The tracker as given (`beatslide@10`).
    pub tracker: String,
    pub trials: usize,
    /// Fraction of trials that followed the requested length.
    pub completion_rate: f64,
    /// Lateral error of every autonomous point of every trial, pooled, m; null when no trial
    /// located any point (an error of 0 would read as perfect on a front).
    pub error_mean_m: Option<f64>,
    pub error_sd_m: Option<f64>,
    pub error_max_m: Option<f64>,
    /// The 95th percentile (nearest rank) and the largest of the absolute lateral error of
    /// the same points, m; null when there are none.
    pub lateral_error_p95_m: Option<f64>,
    pub lateral_error_max_m: Option<f64>,
    /// Located points of all trials (the placements' seed points included) more than
    /// 2 mm (`sim::trial::FALSE_POINT_M`) from the true artery.
    pub false_points: usize,
    /// Heartbeats (pulse cycles) per trial, from the start of autonomous tracking.
    pub beats_mean: f64,
    /// Simulated seconds of autonomous tracking per trial.
    pub duration_s_mean: f64,
    pub backtracks_mean: f64,
    // Beyond the required fields.
    /// The tracker's name and speed setting, m/s (its configured value when not given).
    pub tracker_name: String,
    pub speed_m_s: Option<f64>,
    /// Beats per 26 cm of tracked artery, mean over completed trials (the seed's track
    /// length; the scene's requested length is the divisor).
    pub beats_per_26cm_mean: Option<f64>,
    /// Autonomous points over all trials.
    pub points: usize,
    /// The median over the trials that located points of each one's own lateral error SD, m.
    pub error_sd_trial_median_m: Option<f64>,
    /// The smallest and largest of those per-trial SDs, m (the front's vertical error bar).
    pub error_sd_trial_range_m: Option<[f64; 2]>,
    /// SD over the trials of the autonomous tracking time, s (the front's horizontal bar).
    pub duration_s_sd: f64,
    /// How the trials ended, in trial order.
    pub end_reasons: Vec<String>,
    /// Wall-clock seconds per trial (the only machine-dependent field).
    pub wall_s_mean: f64,
}

/// The whole report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Report {
    /// Seed of the first trial (trial i used seed + i) and trials per row.
    pub seed: u64,
    pub trials: u32,
    pub rows: Vec<Row>,
}

pub fn run(args: &Args) -> ExitCode {
    match run_inner(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => crate::cli::failure::failed("bench", args.json, &message),
    }
}

/// Where a row's trials get their scenes.
#[derive(Debug, Clone)]
enum Source {
    Scene(Box<Scene>),
    /// A family and the scene it drew for each trial, in trial order.
    Family {
        family: Box<LoadedFamily>,
        drawn: Vec<Scene>,
    },
}

impl Source {
    fn name(&self) -> &str {
        match self {
            Source::Scene(s) => &s.name,
            Source::Family { family, .. } => &family.family.name,
        }
    }

    fn scene(&self, trial: usize) -> Option<&Scene> {
        match self {
            Source::Scene(s) => Some(s),
            Source::Family { drawn, .. } => drawn.get(trial),
        }
    }
}

fn run_inner(args: &Args) -> Result<(), String> {
    if args.trials == 0 {
        return Err("--trials must be at least 1".into());
    }
    let config = load_config(args.config.as_deref())?;
    let mut sources = Vec::new();
    if args.task == "search" {
        return run_search_task(args, &config);
    }
    let scene_patterns = match (&args.scenes, &args.families) {
        (Some(p), _) => Some(p.as_str()),
        (None, None) => Some("seed-arc-*,seed-s-curve"),
        (None, Some(_)) => None,
    };
    if let Some(p) = scene_patterns {
        sources.extend(
            select_scenes(p)?
                .into_iter()
                .map(|s| Source::Scene(Box::new(s))),
        );
    }
    if let Some(p) = &args.families {
        for f in select_families(p)? {
            sources.push(draw_family(f, args.trials, args.seed)?);
        }
    }
    if let Some(dir) = &args.dump_scene {
        for f in dump_scenes(&sources, args.seed, dir)? {
            eprintln!("wrote {}", f.display());
        }
    }
    let trackers = parse_trackers(&args.trackers)?;
    let report = bench(&config, &sources, &trackers, args.trials, args.seed, true)?;
    if let Some(dir) = &args.plot {
        for f in plot_fronts(&report, dir).map_err(|e| e.to_string())? {
            eprintln!("wrote {}", f.display());
        }
    }
    if args.json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        outln!("{text}");
    } else {
        print_table(&report);
    }
    Ok(())
}

/// `--task search`: the search against its baseline on drawn regions.
fn run_search_task(args: &Args, config: &Config) -> Result<(), String> {
    use crate::cli::bench_search::{Rig, bench_search, print_table};
    let side_m = args.region_mm * 1e-3;
    if !(args.region_mm.is_finite()
        && (control::search::region::MIN_SIDE_M..=control::search::region::MAX_SIDE_M)
            .contains(&side_m))
    {
        return Err(format!(
            "--region-mm {}: must lie within {} to {} mm",
            args.region_mm,
            control::search::region::MIN_SIDE_M * 1e3,
            control::search::region::MAX_SIDE_M * 1e3
        ));
    }
    let mut methods = Vec::new();
    for m in args
        .methods
        .split(',')
        .map(str::trim)
        .filter(|m| !m.is_empty())
    {
        let method = control::search::SearchMethod::parse(m).ok_or_else(|| {
            format!("--methods: unknown method {m:?}; known methods: search, raster")
        })?;
        if !methods.contains(&method) {
            methods.push(method);
        }
    }
    if methods.is_empty() {
        return Err("--methods: name at least one method (search, raster)".into());
    }
    if args.scenes.is_some() || args.dump_scene.is_some() || args.plot.is_some() {
        return Err(
            "--task search draws its own regions: --scenes, --dump-scene and --plot do not apply (use --families for other rigs)"
                .into(),
        );
    }
    let mut rigs = Vec::new();
    match &args.families {
        Some(p) => {
            for f in select_families(p)? {
                rigs.push(Rig::Family(Box::new(f)));
            }
        }
        None => rigs.push(Rig::Seed(Box::new(
            sim::scene::load("seed-arc-145", None).map_err(|e| e.to_string())?,
        ))),
    }
    let report = bench_search(config, &rigs, &methods, side_m, args.trials, args.seed)?;
    if args.json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        outln!("{text}");
    } else {
        print_table(&report);
    }
    Ok(())
}

/// The family's scenes for trials `0..trials` (seeds `seed + i`).
fn draw_family(family: LoadedFamily, trials: u32, seed: u64) -> Result<Source, String> {
    let drawn = (0..trials)
        .map(|i| family.draw(seed.wrapping_add(u64::from(i))))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Source::Family {
        family: Box::new(family),
        drawn,
    })
}

/// Write every drawn scene into `dir`; returns the files written.
fn dump_scenes(sources: &[Source], seed: u64, dir: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("--dump-scene {}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for source in sources {
        let Source::Family { family, drawn } = source else {
            continue;
        };
        for (i, scene) in drawn.iter().enumerate() {
            let trial_seed = seed.wrapping_add(i as u64);
            let comment = format!(
                "pulsetrack scene drawn from family `{}` with seed {trial_seed}.\nRerun the bench's trial: pulsetrack sim --scene FILE --seed {trial_seed} --tracker NAME",
                family.family.name
            );
            let text = sim::scene::to_ron(scene, &comment)?;
            let file = dir.join(format!("{}.ron", scene.name));
            std::fs::write(&file, text).map_err(|e| format!("{}: {e}", file.display()))?;
            files.push(file);
        }
    }
    Ok(files)
}

/// Run every trial of every scene and tracker (in parallel) and summarize.
fn bench(
    config: &Config,
    sources: &[Source],
    trackers: &[TrackerSpec],
    trials: u32,
    seed: u64,
    progress: bool,
) -> Result<Report, String> {
    // One configuration per tracker spec, checked before any trial runs.
    let mut configs = Vec::with_capacity(trackers.len());
    for t in trackers {
        let mut c = config.clone();
        if let Some(v) = t.speed_m_s {
            c.tracker
                .params
                .set_speed(&t.name, v)
                .map_err(|e| e.to_string())?;
        }
        control::tracker::build(&t.name, &c.tracker.params, &c.sensor)
            .map_err(|e| format!("tracker `{}`: {e}", t.label))?;
        configs.push(c);
    }
    let jobs: Vec<(usize, usize, u32)> = (0..sources.len())
        .flat_map(|s| (0..trackers.len()).flat_map(move |t| (0..trials).map(move |i| (s, t, i))))
        .collect();
    let bar = progress.then(|| Progress::new("bench", Some(jobs.len() as u64)));
    let results: Vec<Result<TrialResult, String>> = jobs
        .par_iter()
        .map(|&(s, t, i)| {
            let trial_seed = seed.wrapping_add(u64::from(i));
            let scene = sources[s]
                .scene(i as usize)
                .ok_or_else(|| format!("{}: no scene drawn for trial {i}", sources[s].name()))?;
            let result = sim::runner::run_trial(scene, &configs[t], &trackers[t].name, trial_seed)
                .map_err(|e| format!("{} with {}: {e}", scene.name, trackers[t].label));
            if let Some(bar) = &bar {
                let end = result
                    .as_ref()
                    .map_or("error", |r| r.end_reason.as_str())
                    .to_string();
                bar.step(&format!(
                    "{} {} seed {trial_seed}: {end}",
                    scene.name, trackers[t].label
                ));
            }
            result
        })
        .collect();
    if let Some(bar) = bar {
        bar.finish();
    }
    let mut rows = Vec::with_capacity(sources.len() * trackers.len());
    let mut it = results.into_iter();
    for source in sources {
        for (t, spec) in trackers.iter().enumerate() {
            let mut trial_results = Vec::with_capacity(trials as usize);
            for _ in 0..trials {
                let r = it.next().ok_or("missing trial result")??;
                trial_results.push(r);
            }
            let speed = spec
                .speed_m_s
                .or_else(|| configs[t].tracker.params.speed(&spec.name));
            rows.push(summarize(source, spec, speed, &trial_results));
        }
    }
    Ok(Report { seed, trials, rows })
}

fn summarize(
    source: &Source,
    spec: &TrackerSpec,
    speed: Option<f64>,
    trials: &[TrialResult],
) -> Row {
    let n = trials.len().max(1) as f64;
    let errors: Vec<f64> = trials
        .iter()
        .flat_map(|t| {
            t.located
                .iter()
                .filter(|p| !p.seed)
                .map(|p| p.lateral_error_m)
        })
        .collect();
    let pooled = LateralError::of(&errors);
    let completed: Vec<&TrialResult> = trials.iter().filter(|t| t.completed).collect();
    // Each trial's own scene's requested length (a family's differ from trial to trial).
    let requested = |i: usize| {
        source
            .scene(i)
            .map_or(REFERENCE_LENGTH_M, |s| s.track.length_m)
    };
    let beats_per_26cm_mean = (!completed.is_empty()).then(|| {
        trials
            .iter()
            .enumerate()
            .filter(|(_, t)| t.completed)
            .map(|(i, t)| t.beats as f64 * REFERENCE_LENGTH_M / requested(i))
            .sum::<f64>()
            / completed.len() as f64
    });
    let mut per_trial_sd: Vec<f64> = trials
        .iter()
        .filter(|t| t.located.iter().any(|p| !p.seed))
        .map(|t| t.lateral_error_m.sd)
        .collect();
    per_trial_sd.sort_by(f64::total_cmp);
    let median_sd = per_trial_sd.get(per_trial_sd.len() / 2).copied();
    let sd_range = per_trial_sd
        .first()
        .zip(per_trial_sd.last())
        .map(|(lo, hi)| [*lo, *hi]);
    let located = pooled.points > 0;
    let mean = |f: &dyn Fn(&TrialResult) -> f64| trials.iter().map(f).sum::<f64>() / n;
    let duration_s_mean = mean(&|t| t.duration_s);
    Row {
        scene: source.name().to_string(),
        family: matches!(source, Source::Family { .. }).then(|| source.name().to_string()),
        tracker: spec.label.clone(),
        trials: trials.len(),
        completion_rate: completed.len() as f64 / n,
        error_mean_m: located.then_some(pooled.mean),
        error_sd_m: located.then_some(pooled.sd),
        error_max_m: located.then_some(pooled.max),
        lateral_error_p95_m: located.then_some(pooled.p95),
        lateral_error_max_m: located.then_some(pooled.max),
        false_points: trials.iter().map(|t| t.false_points).sum(),
        beats_mean: mean(&|t| t.beats as f64),
        duration_s_mean,
        backtracks_mean: mean(&|t| f64::from(t.backtracks)),
        tracker_name: spec.name.clone(),
        speed_m_s: speed,
        beats_per_26cm_mean,
        points: pooled.points,
        error_sd_trial_median_m: median_sd,
        error_sd_trial_range_m: sd_range,
        duration_s_sd: (trials
            .iter()
            .map(|t| (t.duration_s - duration_s_mean).powi(2))
            .sum::<f64>()
            / n)
            .sqrt(),
        end_reasons: trials.iter().map(|t| t.end_reason.clone()).collect(),
        wall_s_mean: mean(&|t| t.wall_s),
    }
}

/// `NAME` or `NAME@SPEED_MM_S`, comma-separated.
fn parse_trackers(list: &str) -> Result<Vec<TrackerSpec>, String> {
    let mut out = Vec::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, speed) = match item.split_once('@') {
            Some((name, mm_s)) => {
                let v: f64 = mm_s.trim().parse().map_err(|_| {
                    format!("--trackers: `{item}`: the speed after `@` must be a number of mm/s")
                })?;
                if !(v.is_finite() && v > 0.0) {
                    return Err(format!("--trackers: `{item}`: the speed must be positive"));
                }
                (name.trim(), Some(v * 1e-3))
            }
            None => (item, None),
        };
        if !control::tracker::TRACKER_NAMES.contains(&name) {
            return Err(format!(
                "--trackers: unknown tracker `{name}`; known trackers: {}",
                control::tracker::TRACKER_NAMES.join(", ")
            ));
        }
        let spec = TrackerSpec {
            label: item.to_string(),
            name: name.to_string(),
            speed_m_s: speed,
        };
        if !out.contains(&spec) {
            out.push(spec);
        }
    }
    if out.is_empty() {
        return Err("--trackers names no tracker".into());
    }
    Ok(out)
}

/// Scenes matching comma-separated glob patterns, in the order of the patterns (each
/// pattern's matches sorted by name); a scene matched twice is run once.
fn select_scenes(patterns: &str) -> Result<Vec<Scene>, String> {
    select("--scenes", patterns, sim::scene::shipped_names())?
        .iter()
        .map(|n| sim::scene::load(n, None).map_err(|e| e.to_string()))
        .collect()
}

/// Families matching comma-separated glob patterns, as [`select_scenes`].
fn select_families(patterns: &str) -> Result<Vec<LoadedFamily>, String> {
    select("--families", patterns, &sim::family::shipped_family_names())?
        .iter()
        .map(|n| sim::family::load(n, None).map_err(|e| e.to_string()))
        .collect()
}

/// Names (shipped) or files matching comma-separated glob patterns, in the order of the
/// patterns (each pattern's matches sorted), each once.
fn select(option: &str, patterns: &str, shipped: &[&str]) -> Result<Vec<String>, String> {
    let mut names: Vec<String> = Vec::new();
    for pattern in patterns.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let mut matched: Vec<String> = if pattern.contains('/') {
            let path = Path::new(pattern);
            let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
            let dir = dir.unwrap_or(Path::new("."));
            let file_pattern = path
                .file_name()
                .and_then(|f| f.to_str())
                .ok_or_else(|| format!("{option}: `{pattern}` names no file"))?;
            let entries = std::fs::read_dir(dir)
                .map_err(|e| format!("{option}: cannot read {}: {e}", dir.display()))?;
            let mut files = Vec::new();
            for entry in entries {
                let entry = entry.map_err(|e| format!("{option}: {}: {e}", dir.display()))?;
                if let Some(name) = entry.file_name().to_str()
                    && glob_match(file_pattern, name)
                    && entry.path().is_file()
                {
                    files.push(entry.path().display().to_string());
                }
            }
            files
        } else {
            shipped
                .iter()
                .filter(|n| {
                    glob_match(pattern, n) || glob_match(pattern, n.trim_end_matches(".ron"))
                })
                .map(|n| n.to_string())
                .collect()
        };
        if matched.is_empty() {
            return Err(format!(
                "{option}: `{pattern}` matches nothing (shipped: {})",
                shipped.join(", ")
            ));
        }
        matched.sort();
        for m in matched {
            if !names.contains(&m) {
                names.push(m);
            }
        }
    }
    Ok(names)
}

/// Shell-style glob: `*` any run of characters, `?` any one, everything else literal.
fn glob_match(pattern: &str, text: &str) -> bool {
    let (p, t): (Vec<char>, Vec<char>) = (pattern.chars().collect(), text.chars().collect());
    let (mut pi, mut ti) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while ti < t.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == t[ti]) {
            pi += 1;
            ti += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some((pi, ti));
            pi += 1;
        } else if let Some((sp, st)) = star {
            pi = sp + 1;
            ti = st + 1;
            star = Some((sp, st + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

fn print_table(report: &Report) {
    outln!(
        "{} trials per row, seeds {} to {}",
        report.trials,
        report.seed,
        report.seed + u64::from(report.trials) - 1
    );
    outln!(
        "{:<22} {:<16} {:>6} {:>8} {:>8} {:>8} {:>8} {:>6} {:>7} {:>7} {:>8} {:>6}",
        "scene",
        "tracker",
        "done",
        "mean mm",
        "sd mm",
        "p95 mm",
        "max mm",
        "false",
        "beats",
        "b/26cm",
        "track s",
        "back"
    );
    for r in &report.rows {
        outln!(
            "{:<22} {:<16} {:>5.0}% {:>8} {:>8} {:>8} {:>8} {:>6} {:>7.1} {:>7} {:>8.1} {:>6.2}",
            r.scene,
            r.tracker,
            100.0 * r.completion_rate,
            millimetres(r.error_mean_m),
            millimetres(r.error_sd_m),
            millimetres(r.lateral_error_p95_m),
            millimetres(r.lateral_error_max_m),
            r.false_points,
            r.beats_mean,
            r.beats_per_26cm_mean
                .map_or("-".to_string(), |b| format!("{b:.1}")),
            r.duration_s_mean,
            r.backtracks_mean
        );
    }
}

/// Metres as millimetres with two decimals, `-` when there is no value.
fn millimetres(m: Option<f64>) -> String {
    m.map_or("-".to_string(), |m| format!("{:.2}", m * 1e3))
}

/// Per scene: mean track time against lateral error SD, one series per tracker through its
/// speed settings (fastest last), each point labelled with its speed and carrying bars: the
/// track time's SD over the trials across, the smallest to largest per-trial error SD up and
/// down. A tracker that located no point at some setting is named in the legend as such.
fn plot_fronts(report: &Report, dir: &Path) -> Result<Vec<PathBuf>, crate::plot::PlotError> {
    let mut files = Vec::new();
    let mut scenes: Vec<&str> = Vec::new();
    for r in &report.rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for scene in scenes {
        let rows: Vec<&Row> = report.rows.iter().filter(|r| r.scene == scene).collect();
        if rows.iter().all(|r| r.error_sd_m.is_none()) {
            // Nothing to place on the axes: the table says why.
            continue;
        }
        let mut chart = Chart::new(
            format!(
                "{scene}: speed against error, {} trials per point, seeds {}-{}",
                report.trials,
                report.seed,
                report.seed + u64::from(report.trials) - 1
            ),
            "mean track time (s)",
            "lateral error SD (mm)",
        );
        let mut names: Vec<&str> = Vec::new();
        for r in &rows {
            if !names.contains(&r.tracker_name.as_str()) {
                names.push(&r.tracker_name);
            }
        }
        for (hue, name) in names.into_iter().enumerate() {
            let mut mine: Vec<&Row> = rows
                .iter()
                .copied()
                .filter(|r| r.tracker_name == name)
                .collect();
            mine.sort_by(|a, b| {
                a.speed_m_s
                    .unwrap_or(0.0)
                    .total_cmp(&b.speed_m_s.unwrap_or(0.0))
            });
            let (placed, unplaced): (Vec<&Row>, Vec<&Row>) =
                mine.into_iter().partition(|r| r.error_sd_m.is_some());
            let speed = |r: &Row| {
                r.speed_m_s.map_or("default speed".to_string(), |v| {
                    format!("{:.0} mm/s", v * 1e3)
                })
            };
            let mut label = name.to_string();
            if !unplaced.is_empty() {
                let at: Vec<String> = unplaced.iter().map(|r| speed(r)).collect();
                label = format!("{label}; located no point at {}", at.join(", "));
            }
            let points = placed
                .iter()
                .map(|r| (r.duration_s_mean, r.error_sd_m.unwrap_or(f64::NAN) * 1e3))
                .collect();
            let bars = placed
                .iter()
                .map(|r| {
                    let [lo, hi] = r.error_sd_trial_range_m.unwrap_or([f64::NAN; 2]);
                    Spread {
                        x: (
                            r.duration_s_mean - r.duration_s_sd,
                            r.duration_s_mean + r.duration_s_sd,
                        ),
                        y: (lo * 1e3, hi * 1e3),
                    }
                })
                .collect();
            chart = chart.with(
                Series::new(label, points, Mark::LinePoints)
                    .hue(Hue::Index(hue))
                    .bars(bars)
                    .labels(placed.iter().map(|r| speed(r)).collect()),
            );
        }
        files.extend(write_chart(&chart, dir, &format!("front_{scene}"))?);
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match("seed-*", "seed-arc-80.ron"));
        assert!(glob_match("seed-arc-?0", "seed-arc-80"));
        assert!(!glob_match("seed-arc-?0", "seed-arc-145"));
        assert!(glob_match("*", ""));
        assert!(glob_match("a*b*c", "aXXbYc"));
        assert!(!glob_match("a*b", "aXXbY"));
    }

    #[test]
    fn tracker_lists() {
        let t = parse_trackers("seed2002, beatslide@12.5,beatslide@12.5").expect("valid");
        assert_eq!(t.len(), 2);
        assert_eq!(t[1].name, "beatslide");
        assert_eq!(t[1].speed_m_s, Some(0.0125));
        for bad in ["", "nope", "beatslide@", "beatslide@-1", "beatslide@x"] {
            assert!(parse_trackers(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn scene_selection() {
        let s = select_scenes("seed-arc-2*,seed-arc-*").expect("shipped");
        let names: Vec<&str> = s.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["seed-arc-220", "seed-arc-145", "seed-arc-80"]);
        assert!(select_scenes("nothing-*").is_err());
        assert!(select_scenes("/nonexistent-dir/*.ron").is_err());
    }

    fn fixed(scenes: Vec<Scene>) -> Vec<Source> {
        scenes
            .into_iter()
            .map(|s| Source::Scene(Box::new(s)))
            .collect()
    }

    fn small_config() -> Config {
        load_config(None).expect("shipped config")
    }

    /// A tracker that never located a point has no error (null), not an error of zero that
    /// would plot as perfect.
    #[test]
    fn no_located_point_gives_null_errors() {
        let config = small_config();
        let scenes = fixed(select_scenes("seed-radial-wrist").expect("shipped"));
        let trackers = parse_trackers("seed2002").expect("valid");
        let report = bench(&config, &scenes, &trackers, 1, 1, false).expect("runs");
        let row = &report.rows[0];
        assert_eq!(row.points, 0, "{row:?}");
        assert_eq!(row.completion_rate, 0.0);
        assert_eq!(row.error_sd_m, None);
        assert_eq!(row.error_mean_m, None);
        assert_eq!(row.error_max_m, None);
        assert_eq!(row.error_sd_trial_median_m, None);
        let json = serde_json::to_value(row).expect("serializes");
        assert!(json["error_sd_m"].is_null(), "{json}");
    }

    /// The JSON has the documented fields, and the same seed gives the same document apart
    /// from wall times, whatever the thread scheduling.
    #[test]
    fn json_schema_and_determinism() {
        let config = small_config();
        let scenes = fixed(select_scenes("seed-arc-220").expect("shipped"));
        let trackers = parse_trackers("seed2002,beatslide@15").expect("valid");
        let strip = |mut r: Report| {
            for row in &mut r.rows {
                row.wall_s_mean = 0.0;
            }
            serde_json::to_value(&r).expect("serializes")
        };
        let a = strip(bench(&config, &scenes, &trackers, 2, 5, false).expect("runs"));
        // A single-threaded pool schedules the jobs differently.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        let b =
            pool.install(|| strip(bench(&config, &scenes, &trackers, 2, 5, false).expect("runs")));
        assert_eq!(a, b);
        let rows = a["rows"].as_array().expect("rows");
        assert_eq!(rows.len(), 2);
        for row in rows {
            for key in [
                "scene",
                "tracker",
                "trials",
                "completion_rate",
                "error_mean_m",
                "error_sd_m",
                "error_max_m",
                "beats_mean",
                "duration_s_mean",
                "backtracks_mean",
                "lateral_error_p95_m",
                "lateral_error_max_m",
                "false_points",
            ] {
                assert!(row.get(key).is_some(), "missing {key} in {row}");
            }
            assert_eq!(row["trials"], 2);
            assert_eq!(row["scene"], "seed-arc-220");
        }
        assert_eq!(rows[1]["tracker"], "beatslide@15");
        assert_eq!(rows[1]["speed_m_s"], 0.015);
        let other = strip(bench(&config, &scenes, &trackers, 2, 6, false).expect("runs"));
        assert_ne!(a, other, "another seed gives other trials");
    }

    /// A family's trials run on the scenes it draws from their seeds; each dumped scene is
    /// an ordinary scene file that reruns the bench's trial exactly.
    #[test]
    fn family_rows_and_dumped_scenes_reproduce_their_trials() {
        let config = small_config();
        let families = select_families("bends").expect("shipped");
        assert!(select_families("no-such-*").is_err());
        let mut family = families.into_iter().next().expect("one");
        // Short tracks keep the test fast.
        family.family.track_length_m = sim::family::Interval(0.03, 0.04);
        let source = draw_family(family, 2, 3).expect("draws");
        let sources = vec![source];
        let trackers = parse_trackers("beatslide").expect("valid");
        let report = bench(&config, &sources, &trackers, 2, 3, false).expect("runs");
        let row = &report.rows[0];
        assert_eq!(row.scene, "bends");
        assert_eq!(row.family.as_deref(), Some("bends"));
        assert_eq!(row.trials, 2);
        let json = serde_json::to_value(row).expect("serializes");
        assert!(json.get("false_points").is_some(), "{json}");
        let dir = std::env::temp_dir().join(format!("pulsetrack-dump-{}", std::process::id()));
        let files = dump_scenes(&sources, 3, &dir).expect("dumps");
        assert_eq!(files.len(), 2);
        let Source::Family { drawn, .. } = &sources[0] else {
            panic!("a family");
        };
        for (i, file) in files.iter().enumerate() {
            assert!(
                file.ends_with(format!("bends-{}.ron", 3 + i)),
                "{}",
                file.display()
            );
            let loaded = sim::scene::load(file.to_str().expect("utf-8"), None).expect("loads");
            assert_eq!(&loaded, &drawn[i]);
            let seed = 3 + i as u64;
            let strip = |mut t: TrialResult| {
                t.wall_s = 0.0;
                serde_json::to_string(&t).expect("serializes")
            };
            let a = sim::runner::run_trial(&drawn[i], &config, "beatslide", seed).expect("runs");
            let b = sim::runner::run_trial(&loaded, &config, "beatslide", seed).expect("runs");
            assert_eq!(strip(a), strip(b));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
