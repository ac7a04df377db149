//! Parsing the `calibrate` verb and the simulator's `place_array` debug hook (a child of the
//! protocol module, for its argument reader).

use super::{Args, CalibrateStep, DebugAction, ErrorCode, RequestError, err};
use serde_json::Value;

/// The procedures the issue names; only those in `BUILT` run.
const PROCEDURES: [&str; 4] = ["tactile", "pivot", "tissue", "joints"];
const BUILT: [&str; 1] = ["tactile"];

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

/// `{"verb": "calibrate", "procedure": "tactile", "step": "tare" | "load", ...}`.
pub(super) fn parse(args: &mut Args) -> Result<CalibrateStep, RequestError> {
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
    if !BUILT.contains(&procedure.as_str()) {
        let why = if PROCEDURES.contains(&procedure.as_str()) {
            format!(
                "the {procedure} procedure is not built yet (docs/rig-bring-up.md); built: {}",
                BUILT.join(", ")
            )
        } else {
            format!(
                "unknown procedure {procedure:?}; known: {}",
                PROCEDURES.join(", ")
            )
        };
        return Err(err(Some(id), ErrorCode::BadArgument, why));
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
