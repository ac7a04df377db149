//! `pulsetrack calibrate PROCEDURE STEP`: runs one step of a rig calibration procedure on the
//! daemon and waits for its result (docs/rig-bring-up.md). The daemon records, judges and
//! writes the calibration file; this prints what it found.

use std::process::ExitCode;
use std::time::Duration;

use serde_json::{Value, json};

use crate::cli::console::Conn;
use crate::cli::failure;
use crate::cli::stdout::outln;
use crate::console::client::Client;

#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    #[command(subcommand)]
    pub procedure: Procedure,
}

/// The procedures of issue 15.
#[derive(Debug, clap::Subcommand)]
pub enum Procedure {
    /// The tactile array: tare with nothing on it, then a known uniform load.
    Tactile {
        #[command(subcommand)]
        step: TactileStep,
    },
    /// The pivot (incision): touch a level plate at five or more points spread in x and z
    /// and fit where the pivot lies across the base; the arm moves on its own (take the
    /// added mass off first).
    Pivot(PivotArgs),
    /// The tissue frame: touch the surface at three or more points (and two along the
    /// artery) and fit where the tissue lies; the arm moves on its own.
    Tissue(TissueArgs),
    /// The joints: the encoder zero from the reset pose (`home`), then each joint's stops
    /// (`sweep`). The instrument must be out of the incision.
    Joints {
        #[command(subcommand)]
        step: JointsStep,
    },
}

#[derive(Debug, clap::Subcommand)]
pub enum JointsStep {
    /// Read the encoders with the unpowered arm resting in its reset pose and measure each
    /// joint's zero offset; if it passes, write it to the calibration file and use it.
    Home(JointsArgs),
    /// After `home`: power the arm (resting unpowered in its reset pose) in joint space and
    /// sweep each joint slowly, torque-capped, to both its stops; write where they are
    /// against the software limits, then bring the arm back and power it off.
    Sweep(SweepArgs),
}

#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    #[command(flatten)]
    pub joints: JointsArgs,
    /// A joint whose stops to find (0, 1 or 2; repeat for more); all three if absent.
    #[arg(long = "joint", value_parser = clap::value_parser!(u8).range(0..3))]
    pub joint: Vec<u8>,
}

#[derive(Debug, clap::Args)]
pub struct JointsArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// Acknowledge that the instrument is out of the incision (the procedure refuses to
    /// run without it: docs/rig-bring-up.md section 1).
    #[arg(long)]
    pub instrument_out: bool,
}

#[derive(Debug, clap::Args)]
pub struct TissueArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// A surface point to touch, mm, tissue frame as configured: x,z. Three or more, across
    /// the patch (repeat the flag).
    #[arg(long = "point", value_name = "X,Z", allow_hyphen_values = true, required = true,
          value_parser = point_mm)]
    pub points: Vec<[f64; 2]>,
    /// Two points along the artery's course, mm: x0,z0,x1,z1 (tissue +x runs from the first
    /// toward the second). Without it the configured yaw is kept.
    #[arg(long, value_name = "X0,Z0,X1,Z1", allow_hyphen_values = true,
          value_parser = course_mm)]
    pub course: Option<[f64; 4]>,
    /// Where the course's line lies across the tissue frame, mm (tissue z; 0: the artery
    /// runs along tissue x, the usual convention).
    #[arg(
        long,
        value_name = "MM",
        allow_hyphen_values = true,
        default_value_t = 0.0,
        requires = "course"
    )]
    pub course_lateral_mm: f64,
}

#[derive(Debug, clap::Args)]
pub struct PivotArgs {
    #[command(flatten)]
    pub conn: Conn,
    /// A point of the level plate to touch, mm, tissue frame as configured: x,z. Five or
    /// more, spread over the plate in x and in z (repeat the flag).
    #[arg(long = "point", value_name = "X,Z", allow_hyphen_values = true, required = true,
          value_parser = point_mm)]
    pub points: Vec<[f64; 2]>,
}

fn point_mm(s: &str) -> Result<[f64; 2], String> {
    crate::cli::lengths::mm_tuple("--point", ["x", "z"], s)
}

fn course_mm(s: &str) -> Result<[f64; 4], String> {
    crate::cli::lengths::mm_tuple("--course", ["x0", "z0", "x1", "z1"], s)
}

#[derive(Debug, clap::Subcommand)]
pub enum TactileStep {
    /// Record the array with nothing touching it: each element's offset and noise.
    Tare {
        #[command(flatten)]
        conn: Conn,
        /// Seconds to record (default: the config's calibration.tactile_recording_s).
        #[arg(long, value_name = "S")]
        duration_s: Option<f64>,
    },
    /// Record it under a known uniform load, finish the calibration, and (if it passes)
    /// write it to the calibration file and use it.
    Load {
        #[command(flatten)]
        conn: Conn,
        /// The known force on each element, N (a flat plate's weight over the elements it
        /// rests on, or a press to a known force).
        #[arg(long, value_name = "N")]
        load_per_element_n: f64,
        /// Seconds to record (default: the config's calibration.tactile_recording_s).
        #[arg(long, value_name = "S")]
        duration_s: Option<f64>,
    },
}

/// The request the command sends, and where to send it.
pub fn request(p: &Procedure) -> (&Conn, Value) {
    match p {
        Procedure::Tactile {
            step: TactileStep::Tare { conn, duration_s },
        } => (
            conn,
            json!({"procedure": "tactile", "step": "tare", "duration_s": duration_s}),
        ),
        Procedure::Tactile {
            step:
                TactileStep::Load {
                    conn,
                    load_per_element_n,
                    duration_s,
                },
        } => (
            conn,
            json!({"procedure": "tactile", "step": "load",
                "load_per_element_n": load_per_element_n, "duration_s": duration_s}),
        ),
        Procedure::Pivot(p) => (
            &p.conn,
            json!({"procedure": "pivot", "step": "touch", "points_m": p.points}),
        ),
        Procedure::Tissue(t) => (
            &t.conn,
            json!({"procedure": "tissue", "step": "touch", "points_m": t.points,
                "course_m": t.course.map(|c| [[c[0], c[1]], [c[2], c[3]]]),
                "course_lateral_m": t.course_lateral_mm * 1e-3}),
        ),
        Procedure::Joints { step } => match step {
            JointsStep::Home(a) => (
                &a.conn,
                json!({"procedure": "joints", "step": "home", "instrument_out": a.instrument_out}),
            ),
            JointsStep::Sweep(s) => {
                let joints = (!s.joint.is_empty()).then(|| s.joint.clone());
                (
                    &s.joints.conn,
                    json!({"procedure": "joints", "step": "sweep",
                            "instrument_out": s.joints.instrument_out, "joints": joints}),
                )
            }
        },
    }
}

const NAME: &str = "calibrate";

pub fn run(args: &CalibrateArgs) -> ExitCode {
    let (conn, req) = request(&args.procedure);
    let mut c = match conn.connect() {
        Ok(c) => c,
        Err(e) => return failure::report(NAME, conn.json, failure::Failure::Unreachable, &e),
    };
    match run_on(&mut c, &req, conn.json) {
        Ok(code) => code,
        Err(e) => failure::failed(NAME, conn.json, &e),
    }
}

fn run_on(c: &mut Client, req: &Value, raw: bool) -> Result<ExitCode, String> {
    const TIMEOUT: Duration = Duration::from_secs(15);
    c.call(
        "subscribe",
        json!({"streams": ["calibration", "faults"], "tactile_every": 1}),
        TIMEOUT,
    )
    .map_err(|e| e.to_string())?;
    let reply = c
        .request(NAME, req.clone(), TIMEOUT)
        .map_err(|e| e.to_string())?;
    if reply["ok"] != Value::Bool(true) {
        crate::cli::console_flow::report_refusal(NAME, &reply, raw);
        return Ok(ExitCode::FAILURE);
    }
    let step = reply["step"].as_str().unwrap_or("?").to_string();
    let procedure = reply["procedure"].as_str().unwrap_or("?").to_string();
    // The recording's own length, or a minute a touch, plus room for a slow simulator.
    let wait = match reply["points"].as_u64() {
        Some(points) => Duration::from_secs(60 * points + 60),
        None => Duration::from_secs_f64(reply["duration_s"].as_f64().unwrap_or(60.0) * 20.0 + 30.0),
    };
    if !raw {
        if procedure == "tissue" || procedure == "pivot" {
            eprintln!("touching {} points ...", reply["points"]);
        } else if procedure == "joints" && step == "sweep" {
            eprintln!(
                "sweeping {} stops (about {:.0} s at the sweep speed) ...",
                reply["stops"],
                num(&reply["duration_s"])
            );
        } else if procedure == "joints" {
            eprintln!("reading the encoders in the reset pose ...");
        } else {
            eprintln!(
                "recording {} frames ({} s) ...",
                reply["frames"], reply["duration_s"]
            );
        }
    }
    let deadline = std::time::Instant::now() + wait;
    loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        if left.is_zero() {
            return Err(format!("no result from the daemon in {} s", wait.as_secs()));
        }
        let Some(e) = c.next_event(left).map_err(|e| e.to_string())? else {
            continue;
        };
        if e["event"] == "fault" {
            return Err(format!(
                "the daemon faulted: {}",
                e["reason"].as_str().unwrap_or("?")
            ));
        }
        if e["event"] != "calibration" || e["step"] != step.as_str() {
            continue;
        }
        match e["phase"].as_str() {
            Some("started") | None => continue,
            Some("stop_found") => {
                if !raw {
                    eprintln!(
                        "  joint {} {} stop: {:.3} deg ({:+.3} deg beyond its software limit){}",
                        e["joint"],
                        e["side"].as_str().unwrap_or("?"),
                        num(&e["at_rad"]).to_degrees(),
                        num(&e["margin_rad"]).to_degrees(),
                        if e["stalled"] == Value::Bool(false) {
                            ", not met: it lies further out"
                        } else {
                            ""
                        }
                    );
                }
                continue;
            }
            Some("touched") => {
                if !raw {
                    let at = |i: usize| num(&e["at_m"][i]) * 1e3;
                    eprintln!(
                        "  touched point {}: ({:.1}, {:.1}) mm, surface {:+.2} mm from the configured one",
                        e["point"],
                        at(0),
                        at(2),
                        at(1)
                    );
                }
                continue;
            }
            Some("failed") => {
                if raw {
                    outln!("{e}");
                } else {
                    eprintln!(
                        "calibrate {procedure} {step}: failed: {}",
                        e["reason"].as_str().unwrap_or("?")
                    );
                }
                return Ok(ExitCode::FAILURE);
            }
            Some(_) => {
                if raw {
                    outln!("{e}");
                } else {
                    print_result(&e);
                }
                // A sweep whose stops are written but fail their margin (one inside its
                // software limit) is not a success either.
                let ok = step == "tare"
                    || (e["applied"] == Value::Bool(true)
                        && (step != "sweep" || e["passed"] == Value::Bool(true)));
                return Ok(if ok {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::FAILURE
                });
            }
        }
    }
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// The tissue frame's result: millimetres and degrees for people.
fn print_tissue(e: &Value) {
    let p = &e["placement"];
    let d = &e["origin_change_m"];
    outln!(
        "tissue frame: yaw {:.3} deg ({:+.3} deg), origin ({:.2}, {:.2}, {:.2}) mm ({:+.2}, {:+.2}, {:+.2} mm), yaw from {}",
        num(&p["yaw_rad"]).to_degrees(),
        num(&e["yaw_change_rad"]).to_degrees(),
        num(&p["origin_in_base_m"][0]) * 1e3,
        num(&p["origin_in_base_m"][1]) * 1e3,
        num(&p["origin_in_base_m"][2]) * 1e3,
        num(&d[0]) * 1e3,
        num(&d[1]) * 1e3,
        num(&d[2]) * 1e3,
        e["yaw_from"].as_str().unwrap_or("?")
    );
    outln!(
        "  surface tilt {:.2} deg; plane residual RMS {:.3} mm, largest {:.3} mm (point {})",
        num(&e["tilt_rad"]).to_degrees(),
        num(&e["rms_residual_m"]) * 1e3,
        num(&e["max_residual_m"]) * 1e3,
        e["worst_point"]
    );
}

/// The sweep's result: degrees for people, and each stop inside its limit said plainly.
fn print_stops(e: &Value) {
    outln!("joint stops: joint side: at deg, software limit deg, beyond it deg");
    for s in e["stops"].as_array().into_iter().flatten() {
        outln!(
            "  {} {:5}: {:8.3} {:8.3} {:+8.3}{}",
            s["joint"],
            s["side"].as_str().unwrap_or("?"),
            num(&s["at_rad"]).to_degrees(),
            num(&s["software_limit_rad"]).to_degrees(),
            num(&s["margin_rad"]).to_degrees(),
            if s["stalled"] == Value::Bool(false) {
                "  (not met within the overtravel)"
            } else {
                ""
            }
        );
    }
    for line in e["stops_inside_limits"].as_array().into_iter().flatten() {
        outln!("WARNING: {}", line.as_str().unwrap_or("?"));
    }
}

/// The homing's result: degrees for people.
fn print_joints(e: &Value) {
    if e["step"] == "sweep" {
        return print_stops(e);
    }
    outln!("encoder zero: joint: reset pose deg, read deg, offset deg");
    for j in 0..3 {
        outln!(
            "  {j}: {:8.3} {:8.3} {:+8.3}",
            num(&e["reset_pose_rad"][j]).to_degrees(),
            num(&e["read_rad"][j]).to_degrees(),
            num(&e["zero_offset_rad"][j]).to_degrees()
        );
    }
}

/// The pivot's result: millimetres for people.
fn print_pivot(e: &Value) {
    let p = &e["pivot_in_base_m"];
    outln!(
        "pivot: ({:.2}, {:.2}, {:.2}) mm in the base frame, moved {:+.2} ± {:.2} mm in x and {:+.2} ± {:.2} mm in z from the one in use",
        num(&p[0]) * 1e3,
        num(&p[1]) * 1e3,
        num(&p[2]) * 1e3,
        num(&e["offset_m"][0]) * 1e3,
        num(&e["standard_error_m"][0]) * 1e3,
        num(&e["offset_m"][1]) * 1e3,
        num(&e["standard_error_m"][1]) * 1e3
    );
    outln!(
        "  level plate residual RMS {:.3} mm, largest {:.3} mm, over {} touches",
        num(&e["rms_residual_m"]) * 1e3,
        num(&e["max_residual_m"]) * 1e3,
        e["touches"]
    );
}

/// Millinewtons for people.
fn print_result(e: &Value) {
    if e["step"] == "tare" {
        outln!(
            "tare: {} frames; element: offset mN, noise SD mN",
            e["frames"]
        );
        let offsets = e["offset_n"].as_array().cloned().unwrap_or_default();
        let noise = e["noise_sd_n"].as_array().cloned().unwrap_or_default();
        for (i, (o, n)) in offsets.iter().zip(&noise).enumerate() {
            outln!("  {i:2}: {:8.2} {:7.2}", num(o) * 1e3, num(n) * 1e3);
        }
        outln!("now put the known load on the array and run `pulsetrack calibrate tactile load`");
        return;
    }
    if e["procedure"] == "tissue" {
        print_tissue(e);
    } else if e["procedure"] == "pivot" {
        print_pivot(e);
    } else if e["procedure"] == "joints" {
        print_joints(e);
    } else {
        print_elements(e);
    }
    print_verdict(e);
}

fn print_elements(e: &Value) {
    outln!(
        "tactile calibration under {:.1} mN per element; element: gain ± SE, offset mN, noise SD mN, status",
        num(&e["load_per_element_n"]) * 1e3
    );
    for el in e["elements"].as_array().into_iter().flatten() {
        outln!(
            "  {:2}: {:6.3} ± {:5.3} {:8.2} {:7.2} {}",
            el["element"],
            num(&el["gain"]),
            num(&el["gain_standard_error"]),
            num(&el["offset_n"]) * 1e3,
            num(&el["noise_sd_n"]) * 1e3,
            el["status"].as_str().unwrap_or("?")
        );
    }
}

fn print_verdict(e: &Value) {
    for c in e["checks"].as_array().into_iter().flatten() {
        outln!(
            "  check {}: {:.4} {} {} -> {}",
            c["quantity"].as_str().unwrap_or("?"),
            num(&c["value"]),
            if c["bound"] == "at_least" { ">=" } else { "<=" },
            num(&c["limit"]),
            if c["passed"] == Value::Bool(true) {
                "pass"
            } else {
                "FAIL"
            }
        );
    }
    if e["applied"] == Value::Bool(true) {
        outln!(
            "passed: written to {} and in use{}",
            e["file"].as_str().unwrap_or("?"),
            match e["unusable_elements"].as_array() {
                Some(_) => format!("; unusable elements {}", e["unusable_elements"]),
                None => String::new(),
            }
        );
    } else {
        outln!(
            "NOT applied: {}",
            e["reason"].as_str().unwrap_or("a check failed")
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(subcommand)]
        procedure: Procedure,
    }

    #[test]
    fn the_tissue_points_are_read_in_millimetres_and_sent_in_metres() {
        let cli = Cli::try_parse_from([
            "calibrate",
            "tissue",
            "--point=-80,45",
            "--point",
            "80, 45",
            "--point=0,-10.5",
            "--course=-110,36.9,115,17.2",
            "--course-lateral-mm",
            "27.2",
        ])
        .expect("parses");
        let (_, req) = request(&cli.procedure);
        assert_eq!(req["procedure"], "tissue");
        assert_eq!(
            req["points_m"],
            json!([[-0.08, 0.045], [0.08, 0.045], [0.0, -0.0105]])
        );
        assert_eq!(req["course_m"], json!([[-0.11, 0.0369], [0.115, 0.0172]]));
        assert!((req["course_lateral_m"].as_f64().expect("lateral") - 0.0272).abs() < 1e-15);
    }

    #[test]
    fn the_pivot_points_are_read_in_millimetres_and_sent_in_metres() {
        let cli = Cli::try_parse_from([
            "calibrate",
            "pivot",
            "--point=-80,45",
            "--point=80,45",
            "--point=-40,10",
            "--point=40,10",
            "--point=0,-60",
        ])
        .expect("parses");
        let (_, req) = request(&cli.procedure);
        assert_eq!(req["procedure"], "pivot");
        assert_eq!(
            req["points_m"],
            json!([
                [-0.08, 0.045],
                [0.08, 0.045],
                [-0.04, 0.01],
                [0.04, 0.01],
                [0.0, -0.06]
            ])
        );
        let e = Cli::try_parse_from(["calibrate", "pivot"])
            .expect_err("no points")
            .to_string();
        assert!(e.contains("--point"), "{e}");
    }

    #[test]
    fn bad_tissue_flags_are_refused_naming_the_flag() {
        for (args, why) in [
            (vec!["calibrate", "tissue"], "--point"),
            (vec!["calibrate", "tissue", "--point=1"], "--point"),
            (vec!["calibrate", "tissue", "--point=1,x"], "z = \"x\""),
            (
                vec!["calibrate", "tissue", "--point=1,2", "--course=1,2,3"],
                "--course",
            ),
            (
                vec![
                    "calibrate",
                    "tissue",
                    "--point=1,2",
                    "--course-lateral-mm",
                    "3",
                ],
                "--course",
            ),
        ] {
            let e = Cli::try_parse_from(&args).expect_err("refused").to_string();
            assert!(e.contains(why), "{args:?}: {e}");
        }
    }
}
