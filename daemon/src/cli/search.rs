//! `pulsetrack search --region X0,Z0,X1,Z1 [--method search|raster] [--heading-deg D]
//! [--then-track [--length-mm L]]`: asks the daemon to find the artery in a region of the tissue surface
//! (millimetres here, metres on the wire; docs/search.md), prints each look and the
//! outcome, and with `--then-track` seeds a track at the two points it found exactly as a
//! surgeon would (move, mark, move, mark, track) and follows it to its end.
//!
//! Exit codes: 0 found (and, with `--then-track`, the track reached its length); 1 not
//! found, stopped, or the track did not complete; 2 a bad command line; 3 the daemon
//! unreachable.

use std::process::ExitCode;
use std::time::Duration;

use serde_json::{Value, json};

use crate::cli::console::{Conn, describe_event, print_summary};
use crate::cli::console_flow::{follow_search, follow_track, wait_mark, wait_state};
use crate::cli::failure;
use crate::cli::stdout::outln;
use crate::console::client::Client;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub conn: Conn,
    /// The region's corners, mm, tissue frame: x0,z0,x1,z1 (any two opposite corners).
    #[arg(long, value_name = "X0,Z0,X1,Z1", allow_hyphen_values = true)]
    pub region: String,
    /// How to explore: `search` (the most information per heartbeat) or `raster`.
    #[arg(long, default_value = "search", value_parser = ["search", "raster"])]
    pub method: String,
    /// The course you expect the artery to take, degrees from +x (default: along x); the
    /// search looks for headings within 60 degrees of it.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub heading_deg: Option<f64>,
    /// Once found, mark the two points and track the artery from them.
    #[arg(long)]
    pub then_track: bool,
    /// With --then-track: how much artery to follow, mm (default: until it is lost).
    #[arg(long, value_name = "MM", requires = "then_track")]
    pub length_mm: Option<f64>,
}

const NAME: &str = "search";
const T: Duration = Duration::from_secs(15);
/// Marks tried at a seed point before giving up (as `demo` and the lockstep runner do).
const MARK_ATTEMPTS: usize = 3;

/// The region's corners in metres, from `x0,z0,x1,z1` in millimetres.
pub fn parse_region(s: &str) -> Result<[f64; 4], String> {
    crate::cli::lengths::mm_tuple("--region", ["x0", "z0", "x1", "z1"], s)
}

pub fn run(args: &Args) -> ExitCode {
    let json_out = args.conn.json;
    let region = match parse_region(&args.region) {
        Ok(r) => r,
        Err(e) => return failure::report(NAME, json_out, failure::Failure::Usage, &e),
    };
    if let Some(h) = args.heading_deg
        && !(h.is_finite() && h.abs() <= 80.0)
    {
        return failure::report(
            NAME,
            json_out,
            failure::Failure::Usage,
            &format!("--heading-deg {h}: must lie within 80 degrees of x"),
        );
    }
    if let Some(l) = args.length_mm
        && !(l.is_finite() && l > 0.0)
    {
        return failure::report(
            NAME,
            json_out,
            failure::Failure::Usage,
            &format!("--length-mm {l}: must be a positive number of millimetres"),
        );
    }
    let mut c = match args.conn.connect() {
        Ok(c) => c,
        Err(e) => return failure::report(NAME, json_out, failure::Failure::Unreachable, &e),
    };
    match run_on(&mut c, args, region) {
        Ok(code) => code,
        Err(e) => failure::failed(NAME, json_out, &e),
    }
}

fn run_on(c: &mut Client, args: &Args, r: [f64; 4]) -> Result<ExitCode, String> {
    let raw = args.conn.json;
    c.call(
        "subscribe",
        json!({"streams": ["search", "faults", "detections", "trials"]}),
        T,
    )
    .map_err(|e| e.to_string())?;
    let reply = c
        .request(
            NAME,
            json!({"x0_m": r[0], "z0_m": r[1], "x1_m": r[2], "z1_m": r[3], "method": args.method,
                "heading_rad": args.heading_deg.map(f64::to_radians)}),
            T,
        )
        .map_err(|e| e.to_string())?;
    if reply["ok"] != Value::Bool(true) {
        crate::cli::console_flow::report_refusal(NAME, &reply, raw);
        return Ok(ExitCode::FAILURE);
    }
    let outcome = follow_search(c, &mut |e, line| {
        if raw {
            outln!("{e}");
        } else if !line.is_empty() {
            outln!("{line}");
        }
    })?;
    if outcome["outcome"] != "found" {
        return Ok(ExitCode::FAILURE);
    }
    if !args.then_track {
        return Ok(ExitCode::SUCCESS);
    }
    let seeds = &outcome["seeds"];
    for i in 0..2 {
        let (Some(x), Some(z)) = (
            seeds[i]["point"]["x_m"].as_f64(),
            seeds[i]["point"]["z_m"].as_f64(),
        ) else {
            return Err("the search's outcome names no seed points".into());
        };
        if !raw {
            outln!(
                "seed {}: moving to ({:.1}, {:.1}) mm and marking",
                i + 1,
                x * 1e3,
                z * 1e3
            );
        }
        c.call("move", json!({"x_m": x, "z_m": z}), T)
            .map_err(|e| e.to_string())?;
        wait_state(c, "holding")?;
        let mut found = false;
        for _ in 0..MARK_ATTEMPTS {
            c.call("mark", json!({}), T).map_err(|e| e.to_string())?;
            found = wait_mark(c, &mut |l| {
                if !raw {
                    outln!("  {l}");
                }
            })?;
            if found {
                break;
            }
            wait_state(c, "holding")?;
        }
        if !found {
            if !raw {
                eprintln!(
                    "search: no pulse at seed {} in {MARK_ATTEMPTS} marks: not tracking",
                    i + 1
                );
            }
            return Ok(ExitCode::FAILURE);
        }
    }
    c.call(
        "track",
        json!({"length_m": args.length_mm.map(|l| l * 1e-3)}),
        T,
    )
    .map_err(|e| e.to_string())?;
    let summary = follow_track(c, &mut |e| {
        if !raw && let Some(line) = describe_event(e) {
            outln!("  {line}");
        }
    })?
    .map_err(|fault| describe_event(&fault).unwrap_or_default())?;
    if raw {
        outln!("{summary}");
    } else {
        print_summary(&summary);
    }
    Ok(if summary["completed"] == Value::Bool(true) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_region_is_read_in_millimetres_and_bad_input_named() {
        assert_eq!(
            parse_region("-20, -20,20,20").expect("region"),
            [-0.02, -0.02, 0.02, 0.02]
        );
        let e = parse_region("1,2,3").expect_err("three");
        assert!(e.contains("four numbers"), "{e}");
        let e = parse_region("1,2,x,4").expect_err("x");
        assert!(e.contains("x1") && e.contains("\"x\""), "{e}");
        assert!(parse_region("1,2,inf,4").is_err());
    }
}
