//! Benchmark of the live view's cost to the 1 kHz loop (not a test): in one run, the real
//! daemon in this process on the embedded simulated bench at time scale 1, arm enabled and
//! holding, for SECONDS in each mode: the live view off; on with nobody connected (`idle`);
//! on with one subscriber (an independent client) reading every channel (`all`), or only
//! `/tactile` (`tactile`). Prints one JSON line per phase.
//!
//! cargo run --release -p pulsetrack-tests --example live_bench -- [SECONDS] [--rounds N]
//!     [--modes off,idle,tactile,all]

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use daemon::console::client::Client;
use daemon::pulsetrackd::{Daemon, LoadedConfig};
use pulsetrack_tests::foxglove_ws::{FoxgloveClient, LIVE_TOPICS as ALL_TOPICS};
use serde_json::{Value, json};

const T: Duration = Duration::from_secs(10);

/// What the live view serves in a phase.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Off,
    Idle,
    Tactile,
    All,
}

impl Mode {
    fn parse(s: &str) -> Result<Self, String> {
        match s {
            "off" => Ok(Mode::Off),
            "idle" => Ok(Mode::Idle),
            "tactile" => Ok(Mode::Tactile),
            "all" => Ok(Mode::All),
            _ => Err(format!(
                "--modes: unknown mode `{s}` (off, idle, tactile, all)"
            )),
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Mode::Off => "off",
            Mode::Idle => "on, nobody connected",
            Mode::Tactile => "on, one subscriber to /tactile",
            Mode::All => "on, one subscriber to every channel",
        }
    }
}

fn phase(seconds: f64, mode: Mode) -> Result<Value, String> {
    let live = mode != Mode::Off;
    let mut loaded = LoadedConfig::load(None).map_err(|e| e.to_string())?;
    let dir = std::env::temp_dir().join(format!("pulsetrack-live-bench-{}", std::process::id()));
    let c = &mut loaded.config;
    c.console.socket_path = dir.join("console.sock").display().to_string();
    c.recording.dir = dir.join("trials").display().to_string();
    // The loop's timing report (status `loop.period`) every second: fresh at the end.
    c.realtime.overrun_report_s = 1.0;
    c.live.enabled = live;
    c.live.port = 0;
    if let config::schema::Backend::Sim(s) = &mut c.backend {
        s.time_scale = 1.0;
    }
    let daemon = Daemon::start(loaded).map_err(|e| e.to_string())?;
    let mut con = Client::connect(daemon.socket_path(), T).map_err(|e| e.to_string())?;
    while con
        .call("status", json!({}), T)
        .map_err(|e| e.to_string())?["tactile"]["frames"]
        .as_u64()
        .unwrap_or(0)
        == 0
    {
        std::thread::sleep(Duration::from_millis(10));
    }
    con.call("enable", json!({}), T)
        .map_err(|e| e.to_string())?;

    let stop = Arc::new(AtomicBool::new(false));
    let received = Arc::new(AtomicU64::new(0));
    let topics: &[&str] = match mode {
        Mode::Tactile => &["/tactile"],
        _ => &ALL_TOPICS,
    };
    let url = daemon.live_url().filter(|_| mode != Mode::Idle);
    let subscriber = match url {
        Some(url) => {
            let mut fox = FoxgloveClient::connect(url, T)?;
            fox.wait_for_channels(topics, T)?;
            fox.subscribe(topics)?;
            let (stop, received) = (Arc::clone(&stop), Arc::clone(&received));
            Some(std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    if let Ok(Some(_)) = fox.next(Duration::from_millis(100)) {
                        received.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }))
        }
        None => None,
    };
    let before = con
        .call("status", json!({}), T)
        .map_err(|e| e.to_string())?;
    std::thread::sleep(Duration::from_secs_f64(seconds));
    let after = con
        .call("status", json!({}), T)
        .map_err(|e| e.to_string())?;
    stop.store(true, Ordering::Relaxed);
    if let Some(s) = subscriber {
        let _ = s.join();
    }
    drop(con);
    daemon.shutdown()?;
    let _ = std::fs::remove_dir_all(&dir);
    let period = &after["loop"]["period"];
    let n = |v: &Value| v.as_u64().unwrap_or(0);
    Ok(json!({
        "live": mode.describe(),
        "seconds": seconds,
        "state": after["state"],
        "loop_cycles": n(&after["loop"]["cycles"]) - n(&before["loop"]["cycles"]),
        "period_us": {
            "p50": period["p50_us"], "p99": period["p99_us"], "p999": period["p999_us"],
            "max": period["max_us"], "cycles": period["cycles"],
        },
        "overruns": after["loop"]["overruns"],
        "skipped": period["skipped"],
        "loop_dropped": after["loop"]["dropped"],
        "live_dropped": after["live"]["dropped"],
        "subscriber_messages": received.load(Ordering::Relaxed),
        "subscriber_messages_per_s": received.load(Ordering::Relaxed) as f64 / seconds,
    }))
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(60.0);
    let rounds: usize = args
        .iter()
        .position(|a| a == "--rounds")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let modes: Vec<Mode> = match args.iter().position(|a| a == "--modes") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--modes needs a list")?
            .split(',')
            .map(Mode::parse)
            .collect::<Result<_, _>>()?,
        None => vec![Mode::Off, Mode::All],
    };
    daemon::service::logging::init("warn");
    for _ in 0..rounds {
        for &mode in &modes {
            println!("{}", phase(seconds, mode)?);
        }
    }
    Ok(())
}
