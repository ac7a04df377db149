//! Benchmark of the daemon (not a test): the 1 kHz loop's period over a span of wall time,
//! idle or with both cores loaded by busy threads, and the console's request round trip.
//!
//! cargo run --release -p pulsetrack-daemon --example daemon_bench -- [SECONDS] [--load] [--requests N]
//!
//! Starts the real daemon in this process on the embedded simulated bench at time scale 1
//! (real time), powers the arm so the servo runs every cycle, waits, then reads the loop's
//! period statistics over its console and times N `status` requests. Prints one JSON object.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use pulsetrack_daemon::console::client::Client;
use pulsetrack_daemon::pulsetrackd::{Daemon, LoadedConfig};
use serde_json::json;

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() as f64 * q).ceil() as usize).clamp(1, sorted.len()) - 1;
    sorted[i]
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(60.0);
    let load = args.iter().any(|a| a == "--load");
    let requests: usize = args
        .iter()
        .position(|a| a == "--requests")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);

    pulsetrack_daemon::service::logging::init("warn");
    let mut loaded = LoadedConfig::load(None).map_err(|e| e.to_string())?;
    let dir = std::env::temp_dir().join(format!("pulsetrack-bench-{}", std::process::id()));
    loaded.config.console.socket_path = dir.join("console.sock").display().to_string();
    loaded.config.recording.dir = dir.join("trials").display().to_string();
    loaded.config.console.max_requests_per_s = 1.0e6;
    // This benchmark measures the daemon as it was before the live view (live_bench has both).
    loaded.config.live.enabled = false;
    if let config::schema::Backend::Sim(s) = &mut loaded.config.backend {
        s.time_scale = 1.0;
    }
    let daemon = Daemon::start(loaded).map_err(|e| e.to_string())?;
    let mut c = Client::connect(daemon.socket_path(), Duration::from_secs(10))
        .map_err(|e| e.to_string())?;
    let t = Duration::from_secs(10);
    while c.call("status", json!({}), t).map_err(|e| e.to_string())?["tactile"]["frames"]
        .as_u64()
        .unwrap_or(0)
        == 0
    {
        std::thread::sleep(Duration::from_millis(10));
    }
    c.call("enable", json!({}), t).map_err(|e| e.to_string())?;

    let stop = Arc::new(AtomicBool::new(false));
    let mut burners = Vec::new();
    if load {
        for _ in 0..2 {
            let stop = Arc::clone(&stop);
            burners.push(std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                }
            }));
        }
    }
    let before = c.call("status", json!({}), t).map_err(|e| e.to_string())?;
    std::thread::sleep(Duration::from_secs_f64(seconds));
    let after = c.call("status", json!({}), t).map_err(|e| e.to_string())?;

    let mut rtt_us = Vec::with_capacity(requests);
    for _ in 0..requests {
        let t0 = Instant::now();
        c.call("status", json!({}), t).map_err(|e| e.to_string())?;
        rtt_us.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    stop.store(true, Ordering::Relaxed);
    for b in burners {
        let _ = b.join();
    }
    rtt_us.sort_by(f64::total_cmp);
    let period = &after["loop"]["period"];
    println!(
        "{}",
        json!({
            "seconds": seconds,
            "load": if load { "two busy threads" } else { "idle" },
            "state": after["state"],
            "loop_cycles": after["loop"]["cycles"].as_u64().unwrap_or(0) - before["loop"]["cycles"].as_u64().unwrap_or(0),
            "period_us": {
                "p50": period["p50_us"], "p99": period["p99_us"], "p999": period["p999_us"], "max": period["max_us"],
                "cycles": period["cycles"],
            },
            "overruns": after["loop"]["overruns"],
            "skipped": period["skipped"],
            "console_rtt_us": {
                "requests": requests,
                "p50": percentile(&rtt_us, 0.5),
                "p99": percentile(&rtt_us, 0.99),
                "max": rtt_us.last(),
            },
        })
    );
    drop(c);
    daemon.shutdown()?;
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
