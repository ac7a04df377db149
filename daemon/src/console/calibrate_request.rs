//! Parsing the `calibrate` verb and the simulator's `place_array` debug hook (a child of the
//! protocol module, for its argument reader).

use super::{Args, CalibrateStep, DebugAction, ErrorCode, ParseLimits, RequestError, err};
use control::frames::SurfacePoint;
use serde_json::Value;

/// The procedures the issue names (all built).
const PROCEDURES: [&str; 4] = ["tactile", "pivot", "tissue", "joints"];

/// Most surface points one tissue or pivot calibration touches (each takes some 15 s).
pub const MAX_TOUCHES: usize = 16;

/// The longest recording a step may ask for, s.
const MAX_DURATION_S: f64 = 600.0;
/// The largest load per element a known load may be, N (the serial protocol's full scale).
const MAX_LOAD_PER_ELEMENT_N: f64 = 3.2767;

fn string(args: &mut Args, name: &str) -> Result<Option<String>, RequestError> {
    match args.obj.remove(name) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::String(s)) => Ok(Some(s)),
        Some(other) => Err(err(
            Some(args.id),
            ErrorCode::BadArgument,
            format!("`{name}` must be a string, got {other}"),
        )),
    }
}

fn load(args: &mut Args) -> Result<f64, RequestError> {
    let l = args.number("load_per_element_n", None)?;
    if !(l > 0.0 && l < MAX_LOAD_PER_ELEMENT_N) {
        return Err(err(
            Some(args.id),
            ErrorCode::OutOfRange,
            format!(
                "`load_per_element_n` = {l} N must be in (0, {MAX_LOAD_PER_ELEMENT_N}) N: the known force on each element"
            ),
        ));
    }
    Ok(l)
}

/// `[[x, z], ...]` in metres: surface points, tissue frame.
fn parse_points(
    args: &mut Args,
    name: &str,
    limits: &ParseLimits,
) -> Result<Option<Vec<SurfacePoint>>, RequestError> {
    let id = args.id;
    let bad = |why: String| Err(err(Some(id), ErrorCode::BadArgument, why));
    let list = match args.obj.remove(name) {
        None | Some(Value::Null) => return Ok(None),
        Some(Value::Array(a)) => a,
        Some(other) => {
            return bad(format!(
                "`{name}` must be a list of [x, z] points in metres, got {other}"
            ));
        }
    };
    let mut out = Vec::with_capacity(list.len());
    for (i, p) in list.iter().enumerate() {
        let xz: Option<Vec<f64>> = p
            .as_array()
            .filter(|a| a.len() == 2)
            .map(|a| a.iter().filter_map(Value::as_f64).collect());
        let Some([x, z]) = xz.as_deref().and_then(|v| <[f64; 2]>::try_from(v).ok()) else {
            return bad(format!(
                "`{name}` point {i} must be [x, z], two numbers in metres, got {p}"
            ));
        };
        for v in [x, z] {
            if !(v.is_finite() && v.abs() <= limits.max_coordinate_m) {
                return Err(err(
                    Some(id),
                    ErrorCode::OutOfRange,
                    format!(
                        "`{name}` point {i} = [{x}, {z}] m is beyond ±{} m",
                        limits.max_coordinate_m
                    ),
                ));
            }
        }
        out.push(SurfacePoint::new(x, z));
    }
    Ok(Some(out))
}

/// A touch procedure's `points_m` (none: empty), its only step being `touch`.
fn touch_points(
    args: &mut Args,
    procedure: &str,
    limits: &ParseLimits,
) -> Result<Vec<SurfacePoint>, RequestError> {
    if let Some(step) = string(args, "step")?
        && step != "touch"
    {
        return Err(err(
            Some(args.id),
            ErrorCode::BadArgument,
            format!("unknown {procedure} step {step:?}; known: touch"),
        ));
    }
    Ok(parse_points(args, "points_m", limits)?.unwrap_or_default())
}

/// `{"verb": "calibrate", "procedure": "tissue", "points_m": [[x, z], ...],
/// "course_m": [[x, z], [x, z]]}`.
fn tissue(args: &mut Args, limits: &ParseLimits) -> Result<CalibrateStep, RequestError> {
    let id = args.id;
    let points = touch_points(args, "tissue", limits)?;
    if !(3..=MAX_TOUCHES).contains(&points.len()) {
        return Err(err(
            Some(id),
            ErrorCode::BadArgument,
            format!(
                "`calibrate` tissue needs `points_m`: 3 to {MAX_TOUCHES} surface points [x, z] to touch, got {}",
                points.len()
            ),
        ));
    }
    let course = match parse_points(args, "course_m", limits)? {
        None => None,
        Some(c) => match <[SurfacePoint; 2]>::try_from(c) {
            Ok(c) => Some(c),
            Err(c) => {
                return Err(err(
                    Some(id),
                    ErrorCode::BadArgument,
                    format!(
                        "`course_m` must be two points along the artery, [[x, z], [x, z]], got {}",
                        c.len()
                    ),
                ));
            }
        },
    };
    let course_lateral_m = args.number("course_lateral_m", Some(0.0))?;
    if course_lateral_m.abs() > limits.max_coordinate_m {
        return Err(err(
            Some(id),
            ErrorCode::OutOfRange,
            format!(
                "`course_lateral_m` = {course_lateral_m} m is beyond ±{} m",
                limits.max_coordinate_m
            ),
        ));
    }
    Ok(CalibrateStep::TissueTouch {
        points,
        course,
        course_lateral_m,
    })
}

/// `{"verb": "calibrate", "procedure": "pivot", "points_m": [[x, z], ...]}`: five or more
/// points of a level plate (their layout is judged by the supervisor, which knows why a
/// layout cannot fix the pivot).
fn pivot(args: &mut Args, limits: &ParseLimits) -> Result<CalibrateStep, RequestError> {
    let id = args.id;
    let min = control::calibration::level_pivot::MIN_TOUCHES;
    let points = touch_points(args, "pivot", limits)?;
    if !(min..=MAX_TOUCHES).contains(&points.len()) {
        return Err(err(
            Some(id),
            ErrorCode::BadArgument,
            format!(
                "`calibrate` pivot needs `points_m`: {min} to {MAX_TOUCHES} points [x, z] of a level plate to touch, spread in x and z, got {}",
                points.len()
            ),
        ));
    }
    Ok(CalibrateStep::PivotTouch { points })
}

/// `{"verb": "calibrate", "procedure": "joints", "step": "home" | "sweep", "instrument_out":
/// true}`: the homing, or the stop sweep (`"joints": [0, 1, 2]`, the joints whose stops to
/// find, all if absent); both need the instrument out of the incision, acknowledged.
fn joints(args: &mut Args) -> Result<CalibrateStep, RequestError> {
    let id = args.id;
    let sweep = match string(args, "step")?.as_deref() {
        None | Some("home") => false,
        Some("sweep") => true,
        Some(other) => {
            return Err(err(
                Some(id),
                ErrorCode::BadArgument,
                format!("unknown joints step {other:?}; known: home, sweep"),
            ));
        }
    };
    let instrument_out = match args.obj.remove("instrument_out") {
        Some(Value::Bool(b)) => b,
        None | Some(Value::Null) => false,
        Some(other) => {
            return Err(err(
                Some(id),
                ErrorCode::BadArgument,
                format!("`instrument_out` must be true or false, got {other}"),
            ));
        }
    };
    if !instrument_out {
        return Err(err(
            Some(id),
            ErrorCode::Refused,
            "`calibrate joints` needs `instrument_out`: true: take the instrument out of the incision and rest the unpowered arm in its reset pose first (docs/rig-bring-up.md section 1)",
        ));
    }
    if !sweep {
        if args.obj.contains_key("joints") {
            return Err(err(
                Some(id),
                ErrorCode::BadArgument,
                "`joints` belongs to the sweep; the homing reads every joint",
            ));
        }
        return Ok(CalibrateStep::JointsHome { instrument_out });
    }
    let joints = match args.obj.remove("joints") {
        None | Some(Value::Null) => vec![0, 1, 2],
        Some(Value::Array(a)) if !a.is_empty() && a.len() <= 3 => {
            let mut out = Vec::with_capacity(a.len());
            for v in a {
                match v.as_u64() {
                    Some(j) if j < 3 && !out.contains(&(j as usize)) => out.push(j as usize),
                    _ => {
                        return Err(err(
                            Some(id),
                            ErrorCode::BadArgument,
                            format!("`joints` holds joint numbers 0, 1 or 2, each once; got {v}"),
                        ));
                    }
                }
            }
            out
        }
        Some(other) => {
            return Err(err(
                Some(id),
                ErrorCode::BadArgument,
                format!(
                    "`joints` must be a list of one to three joint numbers (0, 1, 2), got {other}"
                ),
            ));
        }
    };
    Ok(CalibrateStep::JointsSweep {
        instrument_out,
        joints,
    })
}

/// `{"verb": "calibrate", "procedure": "tactile", "step": "tare" | "load", ...}`, or the
/// tissue or pivot procedure.
pub(super) fn parse(args: &mut Args, limits: &ParseLimits) -> Result<CalibrateStep, RequestError> {
    let id = args.id;
    let procedure = string(args, "procedure")?.ok_or_else(|| {
        err(
            Some(id),
            ErrorCode::BadArgument,
            format!(
                "`calibrate` needs `procedure`: one of {}",
                PROCEDURES.join(", ")
            ),
        )
    })?;
    if !PROCEDURES.contains(&procedure.as_str()) {
        let why = format!(
            "unknown procedure {procedure:?}; known: {}",
            PROCEDURES.join(", ")
        );
        return Err(err(Some(id), ErrorCode::BadArgument, why));
    }
    if procedure == "tissue" {
        return tissue(args, limits);
    }
    if procedure == "pivot" {
        return pivot(args, limits);
    }
    if procedure == "joints" {
        return joints(args);
    }
    let duration_s = args.optional_number("duration_s")?;
    if let Some(d) = duration_s
        && !(d > 0.0 && d <= MAX_DURATION_S)
    {
        return Err(err(
            Some(id),
            ErrorCode::OutOfRange,
            format!("`duration_s` = {d} must be in (0, {MAX_DURATION_S}] s"),
        ));
    }
    match string(args, "step")?.as_deref() {
        Some("tare") => Ok(CalibrateStep::TactileTare { duration_s }),
        Some("load") => Ok(CalibrateStep::TactileLoad {
            load_per_element_n: load(args)?,
            duration_s,
        }),
        Some(other) => Err(err(
            Some(id),
            ErrorCode::BadArgument,
            format!("unknown tactile step {other:?}; known: tare, load"),
        )),
        None => Err(err(
            Some(id),
            ErrorCode::BadArgument,
            "`calibrate` tactile needs `step`: \"tare\" (nothing on the array) or \"load\" (a known load on it)",
        )),
    }
}

/// `{"verb": "debug", "action": "place_array", "on": "bench" | "tissue", ...}`.
pub(super) fn place_array(args: &mut Args) -> Result<DebugAction, RequestError> {
    let id = args.id;
    match string(args, "on")?.as_deref() {
        Some("tissue") => Ok(DebugAction::PlaceArray {
            load_per_element_n: None,
        }),
        Some("bench") => {
            let l = args.number("load_per_element_n", Some(0.0))?;
            if !(0.0..MAX_LOAD_PER_ELEMENT_N).contains(&l) {
                return Err(err(
                    Some(id),
                    ErrorCode::OutOfRange,
                    format!(
                        "`load_per_element_n` = {l} N must be in [0, {MAX_LOAD_PER_ELEMENT_N}) N"
                    ),
                ));
            }
            Ok(DebugAction::PlaceArray {
                load_per_element_n: Some(l),
            })
        }
        _ => Err(err(
            Some(id),
            ErrorCode::BadArgument,
            "`place_array` needs `on`: \"bench\" or \"tissue\"",
        )),
    }
}
