//! Console verbs: `pulsetrack status`, `enable`, `move`, `mark`, `track`, `watch`, ... Each
//! connects to the daemon's socket, sends one request and prints the reply (or, for `track`
//! and `watch`, follows the event stream).

use crate::cli::daemon_config;
use crate::cli::failure::{self, Failure};
use crate::cli::lengths::{self, Metres};
use crate::cli::stdout::outln;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use serde_json::{Value, json};

use crate::console::client::{Client, ClientError};

/// Where to find the daemon.
#[derive(Debug, Clone, clap::Args)]
pub struct Conn {
    /// The daemon's console socket (default: $PULSETRACK_SOCKET, else the config's).
    #[arg(long)]
    pub socket: Option<PathBuf>,
    /// Read the socket path and the daemon's user from this daemon config (default: the
    /// shipped systemd unit's /etc/pulsetrack/lab.ron when installed, else the embedded
    /// sim config a `pulsetrackd` started by hand uses).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Print raw JSON replies and events (and errors as JSON).
    #[arg(long)]
    pub json: bool,
}

impl Conn {
    fn daemon_config(&self) -> Result<crate::pulsetrackd::LoadedConfig, String> {
        daemon_config::load(
            self.config.as_deref(),
            std::path::Path::new(daemon_config::UNIT_CONFIG),
        )
    }

    pub fn socket_path(&self) -> Result<PathBuf, String> {
        if let Some(s) = &self.socket {
            return Ok(s.clone());
        }
        if let Some(s) = std::env::var_os("PULSETRACK_SOCKET")
            && self.config.is_none()
        {
            return Ok(PathBuf::from(s));
        }
        Ok(PathBuf::from(
            self.daemon_config()?.config.console.socket_path,
        ))
    }

    /// Connect to the daemon, trusting only a socket served by root, by this user or by
    /// the config's `console.daemon_user`.
    pub fn connect(&self) -> Result<Client, String> {
        let path = self.socket_path()?;
        let trusted = self.trusted_uids()?;
        Client::connect_trusting(&path, Duration::from_secs(5), &trusted).map_err(|e| e.to_string())
    }

    fn trusted_uids(&self) -> Result<Vec<u32>, String> {
        let loaded = self.daemon_config()?;
        let Some(name) = loaded.config.console.daemon_user else {
            return Ok(Vec::new());
        };
        match nix::unistd::User::from_name(&name) {
            Ok(Some(u)) => Ok(vec![u.uid.as_raw()]),
            Ok(None) => Err(format!(
                "console.daemon_user {name:?} in {} is not a user on this machine",
                loaded.origin
            )),
            Err(e) => Err(format!("looking up console.daemon_user {name:?}: {e}")),
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct Plain {
    #[command(flatten)]
    pub conn: Conn,
}

#[derive(Debug, clap::Args)]
pub struct JogArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// Step along x (tissue frame), mm.
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = lengths::position_mm)]
    pub dx_mm: Option<Metres>,
    /// Step along z (tissue frame), mm.
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = lengths::position_mm)]
    pub dz_mm: Option<Metres>,
    /// Deprecated: the x step in metres; use --dx-mm.
    #[arg(long, hide = true, value_name = "M", allow_hyphen_values = true, value_parser = lengths::position_m, conflicts_with = "dx_mm")]
    pub dx_m: Option<Metres>,
    /// Deprecated: the z step in metres; use --dz-mm.
    #[arg(long, hide = true, value_name = "M", allow_hyphen_values = true, value_parser = lengths::position_m, conflicts_with = "dz_mm")]
    pub dz_m: Option<Metres>,
}

#[derive(Debug, clap::Args)]
pub struct MoveArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// Target x of the sensor centre (tissue frame), mm.
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = lengths::position_mm, required_unless_present = "x_m")]
    pub x_mm: Option<Metres>,
    /// Target z of the sensor centre (tissue frame), mm.
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = lengths::position_mm, required_unless_present = "z_m")]
    pub z_mm: Option<Metres>,
    /// Speed of the move, mm/s (default and upper limit: control.motion.max_speed_m_s).
    #[arg(long, value_name = "MM_PER_S", allow_hyphen_values = true, value_parser = lengths::speed_mm_s)]
    pub speed_mm_s: Option<Metres>,
    /// Deprecated: target x in metres; use --x-mm.
    #[arg(long, hide = true, value_name = "M", allow_hyphen_values = true, value_parser = lengths::position_m, conflicts_with = "x_mm")]
    pub x_m: Option<Metres>,
    /// Deprecated: target z in metres; use --z-mm.
    #[arg(long, hide = true, value_name = "M", allow_hyphen_values = true, value_parser = lengths::position_m, conflicts_with = "z_mm")]
    pub z_m: Option<Metres>,
    /// Deprecated: speed in m/s; use --speed-mm-s.
    #[arg(long, hide = true, value_name = "M_PER_S", allow_hyphen_values = true, value_parser = lengths::speed_m_s, conflicts_with = "speed_mm_s")]
    pub speed_m_s: Option<Metres>,
}

#[derive(Debug, clap::Args)]
pub struct TrackArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// Length of artery to follow, mm; without it, until the artery is lost.
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = lengths::distance_mm)]
    pub length_mm: Option<Metres>,
    /// Deprecated: the length in metres; use --length-mm.
    #[arg(long, hide = true, value_name = "M", allow_hyphen_values = true, value_parser = lengths::distance_m, conflicts_with = "length_mm")]
    pub length_m: Option<Metres>,
    /// What this trial is (subject, specimen, condition), one line of up to 256 bytes:
    /// kept in the trial recording's metadata and in its summary.
    #[arg(long)]
    pub label: Option<String>,
    /// Return once tracking has started.
    #[arg(long)]
    pub detach: bool,
}

#[derive(Debug, clap::Args)]
pub struct WatchArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// Streams: state, tactile, detections, faults, trials, calibration (default: all but
    /// tactile).
    #[arg(long, value_delimiter = ',')]
    pub streams: Vec<String>,
    /// Show every n-th tactile frame.
    #[arg(long, default_value_t = 10)]
    pub tactile_every: u32,
}

/// The console verbs (subcommands of `pulsetrack`).
#[derive(Debug, clap::Subcommand)]
pub enum Verb {
    /// The daemon's state, arm, tactile stream, trial and loop timing.
    Status(Plain),
    /// Power the arm; it holds where it is.
    Enable(Plain),
    /// Remove power (ends a trial).
    Disable(Plain),
    /// Move the sensor to the configured home point.
    Home(Plain),
    /// Move the sensor by a small step (bounded by operation.max_jog_m).
    Jog(JogArgs),
    /// Move the sensor centre to a tissue-frame point.
    Move(MoveArgs),
    /// Acquire here and localize the artery (twice, at two placements, to seed a track).
    Mark(Plain),
    /// Follow the artery from the two seed points and show progress until the trial ends.
    Track(TrackArgs),
    /// Suspend tracking and hold still.
    Pause(Plain),
    /// Continue tracking.
    Resume(Plain),
    /// Stop the current move, mark or track.
    Stop(Plain),
    /// Emergency stop: power off at once and latch a fault.
    Estop(Plain),
    /// Clear a latched fault (the arm stays unpowered).
    Reset(Plain),
    /// Print the daemon's event stream.
    Watch(WatchArgs),
}

impl Verb {
    fn conn(&self) -> &Conn {
        match self {
            Verb::Status(a)
            | Verb::Enable(a)
            | Verb::Disable(a)
            | Verb::Home(a)
            | Verb::Mark(a)
            | Verb::Pause(a)
            | Verb::Resume(a)
            | Verb::Stop(a)
            | Verb::Estop(a)
            | Verb::Reset(a) => &a.conn,
            Verb::Jog(a) => &a.conn,
            Verb::Move(a) => &a.conn,
            Verb::Track(a) => &a.conn,
            Verb::Watch(a) => &a.conn,
        }
    }
}

const TIMEOUT: Duration = Duration::from_secs(15);

impl Verb {
    /// The subcommand's name, for error reports.
    fn name(&self) -> &'static str {
        match self {
            Verb::Track(_) => "track",
            Verb::Watch(_) => "watch",
            other => request(other).map_or("console", |(name, _)| name),
        }
    }
}

pub fn run(verb: &Verb) -> ExitCode {
    let conn = verb.conn();
    let c = match conn.connect() {
        Ok(c) => c,
        Err(e) => return failure::report(verb.name(), conn.json, Failure::Unreachable, &e),
    };
    match run_inner(c, conn, verb) {
        Ok(code) => code,
        Err(e) => failure::failed(verb.name(), conn.json, &e),
    }
}

/// The request a one-shot verb sends (None for `track` and `watch`, which follow events).
pub fn request(verb: &Verb) -> Option<(&'static str, Value)> {
    Some(match verb {
        Verb::Status(_) => ("status", json!({})),
        Verb::Enable(_) => ("enable", json!({})),
        Verb::Disable(_) => ("disable", json!({})),
        Verb::Home(_) => ("home", json!({})),
        Verb::Jog(a) => (
            "jog",
            json!({
                "dx_m": lengths::either(a.dx_mm, a.dx_m).unwrap_or(0.0),
                "dz_m": lengths::either(a.dz_mm, a.dz_m).unwrap_or(0.0),
            }),
        ),
        Verb::Move(a) => (
            "move",
            json!({
                "x_m": lengths::either(a.x_mm, a.x_m),
                "z_m": lengths::either(a.z_mm, a.z_m),
                "speed_m_s": lengths::either(a.speed_mm_s, a.speed_m_s),
            }),
        ),
        Verb::Mark(_) => ("mark", json!({})),
        Verb::Pause(_) => ("pause", json!({})),
        Verb::Resume(_) => ("resume", json!({})),
        Verb::Stop(_) => ("stop", json!({})),
        Verb::Estop(_) => ("estop", json!({})),
        Verb::Reset(_) => ("reset", json!({})),
        Verb::Track(_) | Verb::Watch(_) => return None,
    })
}

fn run_inner(mut c: Client, conn: &Conn, verb: &Verb) -> Result<ExitCode, String> {
    let (name, args) = match verb {
        Verb::Track(a) => {
            let length_m = lengths::either(a.length_mm, a.length_m);
            return track(&mut c, length_m, a.label.as_deref(), a.detach, conn.json);
        }
        Verb::Watch(a) => return watch(&mut c, &a.streams, a.tactile_every, conn.json),
        other => request(other).ok_or("no request for this verb")?,
    };
    let reply = c.request(name, args, TIMEOUT).map_err(|e| e.to_string())?;
    let ok = reply["ok"] == Value::Bool(true);
    if conn.json {
        outln!("{reply}");
    } else if ok {
        if name == "status" {
            print_status(&reply);
        } else {
            outln!(
                "{name}: ok (state {})",
                reply["state"].as_str().unwrap_or("?")
            );
        }
    } else {
        eprintln!(
            "{name}: refused: {} [{}]",
            reply["reason"].as_str().unwrap_or("?"),
            reply["error"].as_str().unwrap_or("?")
        );
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn mm(v: &Value) -> String {
    v.as_f64()
        .map(|m| format!("{:.2} mm", m * 1000.0))
        .unwrap_or_else(|| "-".into())
}

fn print_status(r: &Value) {
    outln!("state      {}", r["state"].as_str().unwrap_or("?"));
    if !r["fault"].is_null() {
        outln!(
            "fault      {}",
            r["fault"]["reason"].as_str().unwrap_or("?")
        );
        if let Some(p) = r["fault"]["flight_recorder"].as_str() {
            outln!("           flight recorder: {p}");
        }
    }
    let b = &r["backend"];
    outln!(
        "backend    {} (time scale {})",
        b["kind"].as_str().unwrap_or("?"),
        b["time_scale"]
    );
    if let Some(s) = b["scene"].as_object() {
        outln!(
            "scene      {}",
            s.get("name").and_then(Value::as_str).unwrap_or("?")
        );
    }
    outln!("clock      {:.3} s", r["t_s"].as_f64().unwrap_or(0.0));
    let a = &r["arm"];
    outln!(
        "sensor     x {}  z {}  (setpoint x {}  z {}), depth {}",
        mm(&a["sensor"]["x_m"]),
        mm(&a["sensor"]["z_m"]),
        mm(&a["setpoint"]["x_m"]),
        mm(&a["setpoint"]["z_m"]),
        mm(&a["depth_m"])
    );
    let cal = &r["calibration"]["tactile"];
    if cal.is_object() {
        outln!(
            "calibrated tactile array of {}: elements {} skipped, noise {:.1} mN",
            cal["measured_utc"].as_str().unwrap_or("?"),
            cal["unusable_elements"],
            cal["noise_sd_n"].as_f64().unwrap_or(f64::NAN) * 1e3
        );
    } else if r["calibration"].is_object() {
        outln!("calibrated (none: the tactile array is read as configured)");
    }
    let tissue = &r["calibration"]["tissue"];
    if tissue.is_object() {
        let p = &tissue["placement"];
        let o = |i: usize| p["origin_in_base_m"][i].as_f64().unwrap_or(f64::NAN) * 1e3;
        outln!(
            "calibrated tissue frame of {}: yaw {:.3} deg, origin ({:.2}, {:.2}, {:.2}) mm, plane residual {:.3} mm",
            tissue["measured_utc"].as_str().unwrap_or("?"),
            p["yaw_rad"].as_f64().unwrap_or(f64::NAN).to_degrees(),
            o(0),
            o(1),
            o(2),
            tissue["rms_residual_m"].as_f64().unwrap_or(f64::NAN) * 1e3
        );
        if let Some(why) = tissue["stale"].as_str() {
            outln!("WARNING: {why}");
        }
    }
    let pivot = &r["calibration"]["pivot"];
    if pivot.is_object() {
        let at = |i: usize| pivot["pivot_in_base_m"][i].as_f64().unwrap_or(f64::NAN) * 1e3;
        let moved = |i: usize| pivot["offset_m"][i].as_f64().unwrap_or(f64::NAN) * 1e3;
        outln!(
            "calibrated pivot of {}: ({:.2}, {:.2}, {:.2}) mm in base, moved x {:+.2} z {:+.2} mm, plate residual {:.3} mm",
            pivot["measured_utc"].as_str().unwrap_or("?"),
            at(0),
            at(1),
            at(2),
            moved(0),
            moved(1),
            pivot["rms_residual_m"].as_f64().unwrap_or(f64::NAN) * 1e3
        );
    }
    let joints = &r["calibration"]["joints"];
    if joints.is_object() {
        let deg = |i: usize| {
            joints["zero_offset_rad"][i]
                .as_f64()
                .unwrap_or(f64::NAN)
                .to_degrees()
        };
        outln!(
            "calibrated encoder zero of {}: offsets ({:+.3}, {:+.3}, {:+.3}) deg",
            joints["measured_utc"].as_str().unwrap_or("?"),
            deg(0),
            deg(1),
            deg(2)
        );
        let stops = joints["stops"].as_array().map_or(&[][..], Vec::as_slice);
        if !stops.is_empty() {
            let each: Vec<String> = stops
                .iter()
                .map(|s| {
                    format!(
                        "{} {} {:.2} deg ({:+.2})",
                        s["joint"],
                        s["side"].as_str().unwrap_or("?"),
                        s["at_rad"].as_f64().unwrap_or(f64::NAN).to_degrees(),
                        s["margin_rad"].as_f64().unwrap_or(f64::NAN).to_degrees()
                    )
                })
                .collect();
            outln!(
                "joint stops of {} (deg beyond the software limit): {}",
                joints["stops_measured_utc"].as_str().unwrap_or("?"),
                each.join(", ")
            );
        }
        for line in joints["stops_inside_limits"]
            .as_array()
            .into_iter()
            .flatten()
        {
            outln!("WARNING: {}", line.as_str().unwrap_or("?"));
        }
    }
    let t = &r["tactile"];
    outln!(
        "tactile    {} frames, newest {} s old, contact {} N",
        t["frames"],
        t["age_s"]
            .as_f64()
            .map(|v| format!("{v:.3}"))
            .unwrap_or("-".into()),
        t["contact_n"]
            .as_f64()
            .map(|v| format!("{v:.3}"))
            .unwrap_or("-".into())
    );
    if let Some(tr) = r["trial"].as_object() {
        outln!(
            "trial      {}: {} seeds, {} located, {} followed",
            tr.get("trial").and_then(Value::as_str).unwrap_or("?"),
            tr.get("seeds").unwrap_or(&Value::Null),
            tr.get("located").unwrap_or(&Value::Null),
            mm(tr.get("followed_m").unwrap_or(&Value::Null))
        );
    }
    let l = &r["loop"];
    let p = &l["period"];
    if p.is_null() {
        outln!(
            "loop       {} cycles, {} overruns; period not reported yet",
            l["cycles"],
            l["overruns"]
        );
    } else {
        outln!(
            "loop       {} cycles, {} overruns; period p50 {} us, p99 {} us, p99.9 {} us, max {:.0} us{}",
            l["cycles"],
            l["overruns"],
            p["p50_us"],
            p["p99_us"],
            p["p999_us"],
            p["max_us"].as_f64().unwrap_or(f64::NAN),
            if p["batched"] == Value::Bool(true) {
                format!(
                    " (1 ms batches; {:.1}x real time)",
                    p["achieved_time_scale"].as_f64().unwrap_or(f64::NAN)
                )
            } else {
                String::new()
            }
        );
    }
}

fn subscribe(c: &mut Client, streams: &[&str], tactile_every: u32) -> Result<(), String> {
    c.call(
        "subscribe",
        json!({"streams": streams, "tactile_every": tactile_every}),
        TIMEOUT,
    )
    .map(|_| ())
    .map_err(|e| e.to_string())
}

/// One line for a stream event.
pub fn describe_event(e: &Value) -> Option<String> {
    let t = e["t_s"].as_f64().unwrap_or(f64::NAN);
    match e["event"].as_str()? {
        "state" if e.get("from").is_some() => Some(format!(
            "[{t:9.3} s] state {} -> {}",
            e["from"].as_str().unwrap_or("?"),
            e["state"].as_str().unwrap_or("?")
        )),
        "state" => None,
        "detection" => match e["kind"].as_str()? {
            "located" => {
                let p = &e["point"];
                Some(format!(
                    "[{t:9.3} s] located{} at x {} z {} (element {:.1})",
                    if p["seed"] == Value::Bool(true) {
                        " seed"
                    } else {
                        ""
                    },
                    mm(&p["x_m"]),
                    mm(&p["z_m"]),
                    p["element"].as_f64().unwrap_or(f64::NAN)
                ))
            }
            "missed" => Some(format!(
                "[{t:9.3} s] no pulse at x {} z {}",
                mm(&e["x_m"]),
                mm(&e["z_m"])
            )),
            "backtracking" => Some(format!(
                "[{t:9.3} s] backtracking toward x {} z {}",
                mm(&e["x_m"]),
                mm(&e["z_m"])
            )),
            "pulse" => Some(format!(
                "[{t:9.3} s] pulse period {:.3} s",
                e["period_s"].as_f64().unwrap_or(f64::NAN)
            )),
            "finished" => Some(format!(
                "[{t:9.3} s] tracking finished: {}",
                e["reason"].as_str().unwrap_or("?")
            )),
            _ => None,
        },
        "fault" => Some(format!(
            "[{t:9.3} s] FAULT {}",
            e["reason"].as_str().unwrap_or("?")
        )),
        "trial" => Some(format!(
            "[{t:9.3} s] trial {} {}{}",
            e["trial"].as_str().unwrap_or("?"),
            e["phase"].as_str().unwrap_or("?"),
            e["end_reason"]
                .as_str()
                .map(|r| format!(" ({r})"))
                .unwrap_or_default()
        )),
        "tactile" => Some(format!(
            "[{t:9.3} s] tactile #{}: {}",
            e["seq"],
            e["force_n"]
                .as_array()
                .map(|a| a
                    .iter()
                    .map(|v| format!("{:6.3}", v.as_f64().unwrap_or(f64::NAN)))
                    .collect::<Vec<_>>()
                    .join(" "))
                .unwrap_or_default()
        )),
        "calibration" => Some(format!(
            "[{t:9.3} s] calibration {} {}: {}",
            e["procedure"].as_str().unwrap_or("?"),
            e["step"].as_str().unwrap_or("?"),
            match e["phase"].as_str() {
                Some("done") if e["step"] == "load" => {
                    if e["applied"] == Value::Bool(true) {
                        format!(
                            "passed, in use (unusable elements {})",
                            e["unusable_elements"]
                        )
                    } else {
                        format!("not applied: {}", e["reason"].as_str().unwrap_or("?"))
                    }
                }
                Some("failed") => format!("failed: {}", e["reason"].as_str().unwrap_or("?")),
                Some(p) => p.to_string(),
                None => "?".to_string(),
            }
        )),
        "search" => Some(match e["kind"].as_str()? {
            "started" => format!(
                "[{t:9.3} s] search ({}) of x {} to {}, z {} to {} started",
                e["method"].as_str().unwrap_or("?"),
                mm(&e["region"]["x0_m"]),
                mm(&e["region"]["x1_m"]),
                mm(&e["region"]["z0_m"]),
                mm(&e["region"]["z1_m"])
            ),
            "look" => format!(
                "[{t:9.3} s] look {} at x {} z {} ({:.1} s): {}; artery here {:.0} %",
                e["looks"],
                mm(&e["at"]["x_m"]),
                mm(&e["at"]["z_m"]),
                e["duration_s"].as_f64().unwrap_or(f64::NAN),
                if e["felt"].is_object() {
                    format!(
                        "felt at x {} z {}",
                        mm(&e["felt"]["point"]["x_m"]),
                        mm(&e["felt"]["point"]["z_m"])
                    )
                } else {
                    "no placed pulse".to_string()
                },
                e["p_present"].as_f64().unwrap_or(f64::NAN) * 100.0
            ),
            "finished" => match e["outcome"].as_str()? {
                "found" => format!(
                    "[{t:9.3} s] search found the artery after {} looks: seeds at x {} z {} and x {} z {}, heading {:.1} deg",
                    e["looks"],
                    mm(&e["seeds"][0]["point"]["x_m"]),
                    mm(&e["seeds"][0]["point"]["z_m"]),
                    mm(&e["seeds"][1]["point"]["x_m"]),
                    mm(&e["seeds"][1]["point"]["z_m"]),
                    e["heading_rad"].as_f64().unwrap_or(f64::NAN).to_degrees()
                ),
                "not_found" => format!(
                    "[{t:9.3} s] search found no artery after {} looks ({}): a pulse under {:.1} mN on its strongest element may have been missed",
                    e["looks"],
                    e["reason"].as_str().unwrap_or("?"),
                    e["weakest_felt_n"].as_f64().unwrap_or(f64::NAN) * 1e3
                ),
                other => format!("[{t:9.3} s] search {other} after {} looks", e["looks"]),
            },
            _ => return None,
        }),
        "lagged" => Some(format!("(missed {} events)", e["dropped"])),
        _ => None,
    }
}

/// Print a line; false once stdout is gone (a closed pipe ends `watch` quietly).
fn emit(line: &str) -> bool {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{line}").and_then(|()| out.flush()).is_ok()
}

fn watch(c: &mut Client, streams: &[String], every: u32, raw: bool) -> Result<ExitCode, String> {
    let names: Vec<&str> = if streams.is_empty() {
        vec!["state", "detections", "faults", "trials", "calibration"]
    } else {
        streams.iter().map(String::as_str).collect()
    };
    subscribe(c, &names, every)?;
    loop {
        match c.next_event(Duration::from_secs(3600)) {
            Ok(Some(e)) => {
                let line = if raw {
                    Some(e.to_string())
                } else {
                    describe_event(&e)
                };
                if let Some(line) = line
                    && !emit(&line)
                {
                    return Ok(ExitCode::SUCCESS);
                }
            }
            Ok(None) => {}
            Err(ClientError::Closed) => return Ok(ExitCode::SUCCESS),
            Err(e) => return Err(e.to_string()),
        }
    }
}

fn track(
    c: &mut Client,
    length_m: Option<f64>,
    label: Option<&str>,
    detach: bool,
    raw: bool,
) -> Result<ExitCode, String> {
    subscribe(c, &["state", "detections", "faults", "trials"], 1)?;
    let r = c
        .call(
            "track",
            json!({"length_m": length_m, "label": label}),
            TIMEOUT,
        )
        .map_err(|e| e.to_string())?;
    if detach {
        outln!("tracking (state {})", r["state"].as_str().unwrap_or("?"));
        return Ok(ExitCode::SUCCESS);
    }
    loop {
        let Some(e) = c
            .next_event(Duration::from_secs(3600))
            .map_err(|e| e.to_string())?
        else {
            continue;
        };
        let line = if raw {
            Some(e.to_string())
        } else {
            describe_event(&e)
        };
        if let Some(line) = line {
            emit(&line);
        }
        match e["event"].as_str() {
            Some("trial") if e["phase"] == "ended" => {
                if !raw {
                    print_summary(&e["summary"]);
                }
                let done = e["summary"]["completed"] == Value::Bool(true);
                return Ok(if done {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::FAILURE
                });
            }
            Some("fault") => return Ok(ExitCode::FAILURE),
            _ => {}
        }
    }
}

/// The trial summary in a few lines.
pub fn print_summary(s: &Value) {
    outln!("trial      {}", s["trial"].as_str().unwrap_or("?"));
    if let Some(l) = s["label"].as_str() {
        outln!("label      {l}");
    }
    outln!(
        "result     {} ({})",
        if s["completed"] == Value::Bool(true) {
            "completed"
        } else {
            "not completed"
        },
        s["end_reason"].as_str().unwrap_or("?")
    );
    outln!(
        "time       {:.1} s tracking, {} heartbeats, {} backtracks",
        s["duration_s"].as_f64().unwrap_or(0.0),
        s["beats"]
            .as_f64()
            .map(|b| format!("{b:.0}"))
            .unwrap_or("-".into()),
        s["backtracks"]
    );
    outln!(
        "followed   {} over {} located points",
        mm(&s["followed_m"]),
        s["located"].as_array().map(Vec::len).unwrap_or(0)
    );
    let e = &s["lateral_error_m"];
    if e.is_null() {
        outln!("error      (no ground truth on this backend)");
    } else {
        outln!(
            "lateral    mean {}, SD {}, max {} over {} points",
            mm(&e["mean"]),
            mm(&e["sd"]),
            mm(&e["max"]),
            e["n"]
        );
    }
    outln!("recording  {}", s["recording"].as_str().unwrap_or("?"));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command};
    use clap::Parser;

    fn parse(args: &[&str]) -> Result<Verb, clap::Error> {
        let cli = Cli::try_parse_from(std::iter::once("pulsetrack").chain(args.iter().copied()))?;
        match cli.command {
            Command::Console(v) => Ok(v),
            other => panic!("not a console verb: {other:?}"),
        }
    }

    fn sent(args: &[&str]) -> (&'static str, Value) {
        let verb = parse(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        request(&verb).unwrap_or_else(|| panic!("{args:?} sends no request"))
    }

    #[test]
    fn millimetres_and_metres_send_the_same_request() {
        let mm = sent(&["move", "--x-mm", "12", "--z-mm", "-2", "--speed-mm-s", "10"]);
        let m = sent(&[
            "move",
            "--x-m",
            "0.012",
            "--z-m",
            "-0.002",
            "--speed-m-s",
            "0.01",
        ]);
        assert_eq!(mm, m);
        assert_eq!(
            mm.1,
            json!({"x_m": 0.012, "z_m": -0.002, "speed_m_s": 0.01}),
            "the wire stays SI"
        );
        assert_eq!(
            sent(&["jog", "--dx-mm", "0.5"]),
            sent(&["jog", "--dx-m", "0.0005", "--dz-m", "0"])
        );
        assert_eq!(
            sent(&["jog", "--dz-mm", "-1.25"]).1,
            json!({"dx_m": 0.0, "dz_m": -0.00125})
        );
        // The forms may be mixed across flags.
        assert_eq!(
            sent(&["move", "--x-mm", "12", "--z-m", "-0.002"]).1["x_m"],
            json!(0.012)
        );
        let track = |args: &[&str]| match parse(args) {
            Ok(Verb::Track(a)) => lengths::either(a.length_mm, a.length_m),
            other => panic!("{other:?}"),
        };
        assert_eq!(
            track(&["track", "--length-mm", "150"]),
            track(&["track", "--length-m", "0.15"])
        );
        assert_eq!(track(&["track"]), None);
    }

    #[test]
    fn both_forms_of_one_flag_are_refused() {
        for (args, a, b) in [
            (
                &["move", "--x-mm", "12", "--x-m", "0.012", "--z-mm", "0"][..],
                "--x-mm",
                "--x-m",
            ),
            (
                &["jog", "--dz-mm", "1", "--dz-m", "0.001"][..],
                "--dz-mm",
                "--dz-m",
            ),
            (
                &[
                    "move",
                    "--x-mm",
                    "1",
                    "--z-mm",
                    "0",
                    "--speed-mm-s",
                    "5",
                    "--speed-m-s",
                    "0.005",
                ][..],
                "--speed-mm-s",
                "--speed-m-s",
            ),
            (
                &["track", "--length-mm", "10", "--length-m", "0.01"][..],
                "--length-mm",
                "--length-m",
            ),
        ] {
            let e = parse(args).expect_err("both forms");
            assert_eq!(
                e.kind(),
                clap::error::ErrorKind::ArgumentConflict,
                "{args:?}"
            );
            let text = e.to_string();
            assert!(text.contains(a) && text.contains(b), "{args:?}: {text}");
            assert_eq!(e.exit_code(), 2, "a usage error");
        }
        let e = parse(&["move", "--z-mm", "0"]).expect_err("x missing");
        assert!(e.to_string().contains("--x-mm"), "{e}");
    }

    #[test]
    fn a_bad_number_is_refused_naming_the_flag() {
        for (args, flag) in [
            (&["move", "--x-mm", "nan", "--z-mm", "0"][..], "--x-mm"),
            (&["move", "--x-mm", "0", "--z-mm", "inf"][..], "--z-mm"),
            (&["move", "--x-m", "12", "--z-mm", "0"][..], "--x-m"),
            (
                &["move", "--x-mm", "0", "--z-mm", "0", "--speed-mm-s", "-1"][..],
                "--speed-mm-s",
            ),
            (&["jog", "--dx-mm", "1e9"][..], "--dx-mm"),
            (&["jog", "--dz-m", "-inf"][..], "--dz-m"),
            (&["track", "--length-mm", "0"][..], "--length-mm"),
        ] {
            let e = parse(args).expect_err("a bad value");
            assert_eq!(
                e.kind(),
                clap::error::ErrorKind::ValueValidation,
                "{args:?}"
            );
            let text = e.to_string();
            assert!(text.contains(&format!("'{flag} ")), "{args:?}: {text}");
        }
    }

    #[test]
    fn the_metre_flags_are_hidden_from_help() {
        use clap::CommandFactory;
        let mut cmd = Cli::command();
        let help = cmd
            .find_subcommand_mut("move")
            .expect("move")
            .render_long_help()
            .to_string();
        assert!(
            help.contains("--x-mm") && help.contains("--speed-mm-s"),
            "{help}"
        );
        assert!(
            !help.contains("--x-m ") && !help.contains("--speed-m-s"),
            "{help}"
        );
    }

    #[test]
    fn calibration_events_read_as_one_line_each() {
        let applied = json!({"event": "calibration", "t_s": 3.0, "procedure": "tactile",
            "step": "load", "phase": "done", "applied": true, "unusable_elements": [6]});
        let line = describe_event(&applied).expect("a line");
        assert!(
            line.contains("tactile load: passed, in use (unusable elements [6])"),
            "{line}"
        );
        let refused = json!({"event": "calibration", "t_s": 3.0, "procedure": "tactile",
            "step": "load", "phase": "done", "applied": false,
            "reason": "cannot write /x: No space left on device"});
        assert!(
            describe_event(&refused)
                .expect("a line")
                .contains("not applied: cannot write")
        );
        let failed = json!({"event": "calibration", "t_s": 1.0, "procedure": "tactile",
            "step": "tare", "phase": "failed", "reason": "stopped"});
        assert!(
            describe_event(&failed)
                .expect("a line")
                .ends_with("tactile tare: failed: stopped")
        );
    }
}
