//! `pulsetrack demo`: the README's first command. Starts the real daemon (in this process,
//! on the embedded simulated bench, its console on a real Unix socket), drives a whole
//! seeded trial over that socket exactly as a surgeon's console would — move to the scene's
//! first placement, mark, second placement, mark, track — shows progress, prints the
//! summary and writes plots. With `--search` it is not shown the artery: it searches a
//! region around the first placement and seeds the track at the two points it found.

use crate::cli::progress::Progress;
use crate::cli::stdout::outln;

use std::cell::RefCell;
use std::io::IsTerminal;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::cli::console::{describe_event, print_summary};
use crate::cli::console_flow::{follow_search, follow_track, wait_mark, wait_state};
use crate::console::client::Client;
use crate::live::layout::LAYOUT;
use crate::live::server::LiveError;
use crate::pulsetrackd::{Daemon, LoadedConfig, StartError};
use crate::recording::recover;
use crate::recording::topics::Topic;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// A shipped scene by name or a scene file (default: the embedded config's scene).
    #[arg(long)]
    pub scene: Option<String>,
    /// Simulated seconds per wall second.
    #[arg(long, default_value_t = 25.0)]
    pub time_scale: f64,
    /// Random seed of the simulated bench.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Tracker by name (default: the config's, `seed2002`).
    #[arg(long)]
    pub tracker: Option<String>,
    /// Where the recording, the summary and the plots go.
    #[arg(long, default_value = "pulsetrack-demo")]
    pub out: PathBuf,
    /// Print the trial summary (as in summary.json) as one JSON document on stdout; the
    /// narration goes to stderr.
    #[arg(long)]
    pub json: bool,
    /// Find the artery first (docs/search.md) in a square region around the scene's first
    /// placement, and seed the track at the two points found instead of the placements.
    #[arg(long)]
    pub search: bool,
    /// With --search: the region's side, mm.
    #[arg(long, default_value_t = 40.0, requires = "search")]
    pub region_mm: f64,
}

/// Where the demo's narration goes: stdout, or stderr when stdout carries `--json`'s
/// summary; while tracking, around the spinner on a terminal.
#[derive(Debug)]
struct Say {
    json: bool,
    progress: RefCell<Option<Progress>>,
}

impl Say {
    fn line(&self, args: std::fmt::Arguments<'_>) {
        let text = args.to_string();
        match (self.progress.borrow().as_ref(), self.json) {
            (Some(p), true) => p.note(&text),
            (Some(p), false) => p.suspend(|| outln!("{text}")),
            (None, true) => eprintln!("{text}"),
            (None, false) => outln!("{text}"),
        }
    }

    /// While tracking: a spinner counting located points (plain lines do without one).
    fn tracking(&self, on: bool) {
        // Without a terminal the located points' own lines are the progress.
        let progress =
            (on && std::io::stderr().is_terminal()).then(|| Progress::new("tracking", None));
        if let Some(old) = self.progress.replace(progress) {
            old.finish();
        }
    }

    fn located(&self, n: usize) {
        if let Some(p) = self.progress.borrow().as_ref() {
            p.status(&format!("{n} points located"));
        }
    }
}

macro_rules! say {
    ($say:expr) => {
        $say.line(format_args!(""))
    };
    ($say:expr, $($arg:tt)*) => {
        $say.line(format_args!($($arg)*))
    };
}

const T: Duration = Duration::from_secs(30);

/// Marks tried at one placement before giving up.
const MARK_ATTEMPTS: usize = 3;

pub fn run(args: &Args) -> ExitCode {
    match run_inner(args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => crate::cli::failure::failed("demo", args.json, &e),
    }
}

fn demo_config(args: &Args, out: &Path) -> Result<LoadedConfig, String> {
    let mut loaded = LoadedConfig::load(None).map_err(|e| e.to_string())?;
    let c = &mut loaded.config;
    if let config::schema::Backend::Sim(s) = &mut c.backend {
        if let Some(scene) = &args.scene {
            s.scene = scene.clone();
        }
        if let Some(seed) = args.seed {
            s.seed = seed;
        }
        if !(args.time_scale.is_finite() && (0.01..=1.0e6).contains(&args.time_scale)) {
            return Err(format!(
                "--time-scale {} must be in 0.01..1e6",
                args.time_scale
            ));
        }
        s.time_scale = args.time_scale;
    }
    if let Some(t) = &args.tracker {
        c.tracker.name = t.clone();
    }
    // A private socket: the demo must not collide with a daemon already running.
    let sock_dir = socket_dir();
    c.console.socket_path = sock_dir.join("console.sock").display().to_string();
    c.recording.dir = out.join("trials").display().to_string();
    c.realtime.lock_memory = false;
    // Scenes given as paths resolve against the working directory.
    loaded.dir = std::env::current_dir().ok();
    Ok(loaded)
}

/// Under this user's runtime directory, not a guessable name in /tmp that another user
/// could make first.
fn socket_dir() -> PathBuf {
    crate::runtime_paths::Env::current()
        .runtime_dir()
        .join(format!("demo-{}", std::process::id()))
}

fn run_inner(args: &Args) -> Result<bool, String> {
    let say = &Say {
        json: args.json,
        progress: RefCell::new(None),
    };
    let out = &args.out;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let out = out
        .canonicalize()
        .map_err(|e| format!("{}: {e}", out.display()))?;
    crate::service::logging::init("warn");
    let loaded = demo_config(args, &out)?;
    let wall0 = Instant::now();
    say!(
        say,
        "pulsetrack demo: starting pulsetrackd on the simulated bench ({}x real time)",
        args.time_scale
    );
    let artery = true_path(&loaded);
    let daemon = start_daemon(say, loaded)?;
    if let Some(url) = daemon.live_url() {
        let layout = out.join("pulsetrack-layout.json");
        let layout = match std::fs::write(&layout, LAYOUT) {
            Ok(()) => layout.display().to_string(),
            Err(e) => format!("not written ({}: {e})", layout.display()),
        };
        say!(
            say,
            "live view: {url} (Foxglove: Open connection, Foxglove WebSocket; --time-scale 1 to watch at real time)"
        );
        say!(
            say,
            "layout:   {layout} (Foxglove: Layouts, Import from file)"
        );
    }
    let search = args.search.then_some(args.region_mm * 1e-3);
    let result = drive(say, &daemon, &out, wall0, &artery, search);
    say.tracking(false);
    let stopped = daemon.shutdown();
    // The daemon has exited its lock: the demo's private folder can go.
    let _ = std::fs::remove_file(socket_dir().join("console.sock.lock"));
    let _ = std::fs::remove_dir(socket_dir());
    stopped.map_err(|e| format!("daemon shutdown: {e}"))?;
    result
}

/// The daemon on the demo's config; if the live view's port is taken (a daemon already
/// serving it), on any free port instead.
fn start_daemon(say: &Say, loaded: LoadedConfig) -> Result<Daemon, String> {
    match Daemon::start(loaded.clone()) {
        Err(StartError::Live(LiveError::Bind { addr, source })) => {
            say!(
                say,
                "live view: {addr} is taken ({source}); using any free port"
            );
            let mut loaded = loaded;
            loaded.config.live.port = 0;
            Daemon::start(loaded).map_err(|e| e.to_string())
        }
        r => r.map_err(|e| e.to_string()),
    }
}

/// The scene's true artery path, sampled every millimetre, for the top view (mm).
fn true_path(loaded: &LoadedConfig) -> Vec<(f64, f64)> {
    let config::schema::Backend::Sim(s) = &loaded.config.backend else {
        return Vec::new();
    };
    let Ok(scene) = sim::scene::load(&s.scene, loaded.dir.as_deref()) else {
        return Vec::new();
    };
    sim::scene::ArteryPath::from_spec(&scene.artery.path)
        .map(|p| {
            p.sample(0.001)
                .iter()
                .map(|q| (q.x_m * 1e3, q.z_m * 1e3))
                .collect()
        })
        .unwrap_or_default()
}

fn drive(
    say: &Say,
    daemon: &Daemon,
    out: &Path,
    wall0: Instant,
    artery: &[(f64, f64)],
    search_side_m: Option<f64>,
) -> Result<bool, String> {
    let mut c = Client::connect(daemon.socket_path(), T).map_err(|e| e.to_string())?;
    say!(
        say,
        "console:  {} (protocol {})",
        daemon.socket_path().display(),
        c.hello["protocol"]
    );
    c.call(
        "subscribe",
        json!({"streams": ["state", "detections", "faults", "trials"]}),
        T,
    )
    .map_err(|e| e.to_string())?;
    let status = wait_live(&mut c)?;
    let scene = &status["backend"]["scene"];
    let name = scene["name"].as_str().unwrap_or("?").to_string();
    let p = |i: usize, k: usize| scene["placements"][i][k].as_f64();
    let (Some(x1), Some(z1), Some(x2), Some(z2)) = (p(0, 0), p(0, 1), p(1, 0), p(1, 1)) else {
        return Err("the daemon's status names no scene placements (not the sim backend?)".into());
    };
    let length_m = scene["tracked_length_m"].as_f64();
    say!(
        say,
        "scene:    {name}: placements ({:.1}, {:.1}) and ({:.1}, {:.1}) mm, track {}",
        x1 * 1e3,
        z1 * 1e3,
        x2 * 1e3,
        z2 * 1e3,
        length_m
            .map(|l| format!("{:.0} mm", l * 1e3))
            .unwrap_or_else(|| "until lost".into())
    );

    c.call("enable", json!({}), T).map_err(|e| e.to_string())?;
    let placements = match search_side_m {
        None => [(x1, z1), (x2, z2)],
        Some(side) => match search_seeds(say, &mut c, (x1, z1), side)? {
            Some(seeds) => seeds,
            None => return Ok(false),
        },
    };
    for (i, (x, z)) in placements.into_iter().enumerate() {
        say!(
            say,
            "placement {}: moving to ({:.1}, {:.1}) mm",
            i + 1,
            x * 1e3,
            z * 1e3
        );
        c.call("move", json!({"x_m": x, "z_m": z}), T)
            .map_err(|e| e.to_string())?;
        wait_state(&mut c, "holding")?;
        // A surgeon who feels nothing marks again; so does the simulator's lockstep runner.
        let mut found = false;
        for attempt in 1..=MARK_ATTEMPTS {
            let again = if attempt > 1 {
                format!(", attempt {attempt}")
            } else {
                String::new()
            };
            say!(
                say,
                "placement {}: marking (acquiring the pulse here){again}",
                i + 1
            );
            c.call("mark", json!({}), T).map_err(|e| e.to_string())?;
            found = wait_mark(&mut c, &mut |l| say!(say, "  {l}"))?;
            if found {
                break;
            }
            say!(say, "  no pulse found");
            wait_state(&mut c, "holding")?;
        }
        if !found {
            say!(
                say,
                "no pulse found at placement {} in {MARK_ATTEMPTS} marks: the trial cannot be seeded",
                i + 1
            );
            return Ok(false);
        }
    }
    say!(say, "tracking...");
    say.tracking(true);
    let mut located = 0;
    c.call("track", json!({"length_m": length_m}), T)
        .map_err(|e| e.to_string())?;
    let followed = follow_track(&mut c, &mut |e| {
        if e["kind"] == "located" {
            located += 1;
            say.located(located);
        }
        if let Some(line) = describe_event(e) {
            say!(say, "  {line}");
        }
    })?;
    let summary = match followed {
        Ok(summary) => summary,
        Err(fault) => {
            say!(say, "{}", describe_event(&fault).unwrap_or_default());
            return Ok(false);
        }
    };
    say.tracking(false);
    if say.json {
        outln!("{summary}");
    } else {
        say!(say);
        print_summary(&summary);
    }
    say!(say, "wall time  {:.1} s", wall0.elapsed().as_secs_f64());
    let plots = out.join("plots");
    match write_plots(&summary, &plots, artery) {
        Ok(n) => say!(
            say,
            "plots      {} ({n} charts, PNG and SVG)",
            plots.display()
        ),
        Err(e) => say!(say, "plots      not written: {e}"),
    }
    let summary_path = out.join("summary.json");
    crate::recording::recorder::write_json_atomically(&summary_path, &summary)
        .map_err(|e| format!("{}: {e}", summary_path.display()))?;
    say!(say, "summary    {}", summary_path.display());
    Ok(summary["completed"] == Value::Bool(true))
}

/// Search a square of `side_m` centred on `around` and return the two seed points found
/// (`None`: not found, said why).
fn search_seeds(
    say: &Say,
    c: &mut Client,
    around: (f64, f64),
    side_m: f64,
) -> Result<Option<[(f64, f64); 2]>, String> {
    let h = side_m / 2.0;
    say!(
        say,
        "search:   a {:.0} mm square around ({:.1}, {:.1}) mm, not shown where the artery runs",
        side_m * 1e3,
        around.0 * 1e3,
        around.1 * 1e3
    );
    c.call(
        "subscribe",
        json!({"streams": ["state", "detections", "faults", "trials", "search"]}),
        T,
    )
    .map_err(|e| e.to_string())?;
    c.call(
        "search",
        json!({"x0_m": around.0 - h, "z0_m": around.1 - h, "x1_m": around.0 + h, "z1_m": around.1 + h}),
        T,
    )
    .map_err(|e| e.to_string())?;
    let end = follow_search(c, &mut |_, line| say!(say, "  {line}"))?;
    if end["outcome"] != "found" {
        return Ok(None);
    }
    let p = |i: usize, k: &str| end["seeds"][i]["point"][k].as_f64();
    match (p(0, "x_m"), p(0, "z_m"), p(1, "x_m"), p(1, "z_m")) {
        (Some(a), Some(b), Some(x), Some(z)) => {
            wait_state(c, "holding")?;
            Ok(Some([(a, b), (x, z)]))
        }
        _ => Err("the search's outcome names no seed points".into()),
    }
}

/// Status once the tactile stream is live.
fn wait_live(c: &mut Client) -> Result<Value, String> {
    let deadline = Instant::now() + T;
    loop {
        let s = c.call("status", json!({}), T).map_err(|e| e.to_string())?;
        if s["tactile"]["frames"].as_u64().unwrap_or(0) > 0 {
            return Ok(s);
        }
        if Instant::now() > deadline {
            return Err("no tactile frames from the simulator".into());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Top view, lateral error against distance, and a 4 s trace of all ten elements.
fn write_plots(summary: &Value, dir: &Path, artery: &[(f64, f64)]) -> Result<usize, String> {
    use crate::plot::{Chart, Hue, Mark, Series, write_chart};
    let recording = summary["recording"].as_str().ok_or("no recording")?;
    let back = recover::read(Path::new(recording)).map_err(|e| e.to_string())?;
    let located: Vec<&Value> = summary["located"]
        .as_array()
        .map(|a| a.iter().collect())
        .unwrap_or_default();
    let pts = |kx: &str, kz: &str| -> Vec<(f64, f64)> {
        located
            .iter()
            .filter_map(|p| Some((p[kx].as_f64()? * 1e3, p[kz].as_f64()? * 1e3)))
            .collect()
    };
    let mut top = Chart::new("Top view", "x (mm, along the artery)", "z (mm, lateral)");
    top.equal_aspect = true;
    let believed: Vec<(f64, f64)> = back
        .on(Topic::Joints)
        .filter_map(|m| {
            Some((
                m.json["sensor_x_m"].as_f64()? * 1e3,
                m.json["sensor_z_m"].as_f64()? * 1e3,
            ))
        })
        .collect();
    let truth: Vec<(f64, f64)> = back
        .on(Topic::Truth)
        .filter_map(|m| {
            Some((
                m.json["sensor_x_m"].as_f64()? * 1e3,
                m.json["sensor_z_m"].as_f64()? * 1e3,
            ))
        })
        .collect();
    if !artery.is_empty() {
        top = top
            .with(Series::new("artery (true path)", artery.to_vec(), Mark::Line).hue(Hue::Truth));
    }
    if !truth.is_empty() {
        top = top.with(Series::new("sensor centre (true)", truth, Mark::Line));
    }
    if !believed.is_empty() {
        top = top.with(Series::new(
            "sensor centre (believed)",
            believed,
            Mark::Line,
        ));
    }
    top = top.with(Series::new(
        "located artery points",
        pts("x_m", "z_m"),
        Mark::Points,
    ));
    let mut n = 0;
    write_chart(&top, dir, "top_view").map_err(|e| e.to_string())?;
    n += 1;

    let mut along = 0.0;
    let mut prev: Option<(f64, f64)> = None;
    let mut err = Vec::new();
    for p in &located {
        let (Some(x), Some(z)) = (p["x_m"].as_f64(), p["z_m"].as_f64()) else {
            continue;
        };
        if let Some((px, pz)) = prev {
            along += (x - px).hypot(z - pz);
        }
        prev = Some((x, z));
        if let Some(e) = p["lateral_error_m"].as_f64() {
            err.push((along * 1e3, e * 1e3));
        }
    }
    if !err.is_empty() {
        let c = Chart::new(
            "Lateral error of located points",
            "distance followed (mm)",
            "lateral error (mm)",
        )
        .with(Series::new("located points", err, Mark::LinePoints));
        write_chart(&c, dir, "lateral_error").map_err(|e| e.to_string())?;
        n += 1;
    }

    let frames: Vec<&recover::ReadMessage> = back.on(Topic::Tactile).collect();
    if let Some(first) = frames.first() {
        let t0 = first.json["t_s"].as_f64().unwrap_or(0.0);
        let mut c = Chart::new("Tactile array, first 4 s", "t (s)", "force (N)");
        for el in 0..control::types::ELEMENTS {
            let s: Vec<(f64, f64)> = frames
                .iter()
                .filter_map(|m| {
                    let t = m.json["t_s"].as_f64()? - t0;
                    (t <= 4.0).then_some((t, m.json["force_n"][el].as_f64()?))
                })
                .collect();
            c = c.with(Series::new(format!("element {el}"), s, Mark::Line));
        }
        write_chart(&c, dir, "tactile_trace").map_err(|e| e.to_string())?;
        n += 1;
    }
    Ok(n)
}
