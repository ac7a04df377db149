//! The console protocol: newline-delimited JSON over a Unix socket (see
//! docs/console-protocol.md). The server greets with a hello; each request carries an `id`
//! and a `verb`; each reply repeats the id with `ok: true` or `ok: false` plus an error code
//! and a reason; subscribers also receive `event` lines.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// Bumped on any incompatible change to requests, replies or events.
pub const PROTOCOL_VERSION: u32 = 1;

/// Streams a client may subscribe to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stream {
    /// Operating state changes and a periodic state heartbeat.
    State,
    /// Tactile frames (decimated on request).
    Tactile,
    /// What the tracker found: located points, misses, backtracks, the pulse, the end.
    Detections,
    /// Latched faults.
    Faults,
    /// Trial start and end (with the summary).
    Trials,
    /// Calibration recordings: started, and their results.
    Calibration,
    /// Autonomous searches: started, every look, and how each ended.
    Search,
}

impl Stream {
    pub const ALL: [Stream; 7] = [
        Stream::State,
        Stream::Tactile,
        Stream::Detections,
        Stream::Faults,
        Stream::Trials,
        Stream::Calibration,
        Stream::Search,
    ];
}

/// A verb with its arguments, already checked for type and range.
#[derive(Debug, Clone, PartialEq)]
pub enum Verb {
    Status,
    Enable,
    Disable,
    Home,
    Jog {
        dx_m: f64,
        dz_m: f64,
    },
    Move {
        x_m: f64,
        z_m: f64,
        speed_m_s: Option<f64>,
    },
    Mark,
    Track {
        length_m: Option<f64>,
        /// What the trial is (subject, specimen, condition): kept in its metadata and summary.
        label: Option<String>,
    },
    Pause,
    Resume,
    Stop,
    Estop,
    Reset,
    Subscribe {
        streams: Vec<Stream>,
        tactile_every: u32,
    },
    Unsubscribe,
    /// A step of a rig calibration procedure.
    Calibrate(CalibrateStep),
    /// Find the artery in a region of the tissue surface (docs/search.md).
    Search {
        region: control::search::Region,
        method: control::search::SearchMethod,
        /// The surgeon's expected course, rad from `+x`.
        heading_rad: Option<f64>,
    },
    /// Test hooks, refused unless `console.debug_hooks` is set.
    Debug(DebugAction),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DebugAction {
    /// Drop tactile frames at the loop for this long (daemon clock), as if the stream died.
    SilenceTactile { duration_s: f64 },
    /// The simulator only: take the array off the tissue onto the calibration bench under a
    /// uniform load per element, N (0: nothing on it), or (`None`) put it back.
    PlaceArray { load_per_element_n: Option<f64> },
}

/// A step of a calibration procedure (docs/rig-bring-up.md).
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrateStep {
    /// Record the tactile array with nothing touching it: each element's offset and noise.
    TactileTare { duration_s: Option<f64> },
    /// Record it under a known uniform load and finish its calibration (after a tare).
    TactileLoad {
        load_per_element_n: f64,
        duration_s: Option<f64>,
    },
    /// Touch the tissue surface at `points` (and at the two `course` points along the
    /// artery), tissue frame as configured, and fit the tissue frame to the touches.
    TissueTouch {
        points: Vec<control::frames::SurfacePoint>,
        course: Option<[control::frames::SurfacePoint; 2]>,
        /// Tissue `z` of the line through the course points, m (0: the artery along `x`).
        course_lateral_m: f64,
    },
    /// Touch a level plate at `points` (five or more, spread in `x` and `z`), tissue frame
    /// as configured, and fit the pivot's horizontal place to the touches.
    PivotTouch {
        points: Vec<control::frames::SurfacePoint>,
    },
    /// The homing: the unpowered arm rests in its reset pose, the instrument out of the
    /// incision (`instrument_out` acknowledges it); each joint's encoder zero offset.
    JointsHome { instrument_out: bool },
    /// The stop sweep: the arm, resting unpowered in its reset pose with the instrument out
    /// (`instrument_out` acknowledges it), powered in joint space and each named joint swept
    /// slowly to both its stops with a capped torque.
    JointsSweep {
        instrument_out: bool,
        joints: Vec<usize>,
    },
}

impl CalibrateStep {
    pub fn procedure(&self) -> &'static str {
        match self {
            CalibrateStep::TactileTare { .. } | CalibrateStep::TactileLoad { .. } => "tactile",
            CalibrateStep::TissueTouch { .. } => "tissue",
            CalibrateStep::PivotTouch { .. } => "pivot",
            CalibrateStep::JointsHome { .. } | CalibrateStep::JointsSweep { .. } => "joints",
        }
    }

    pub fn step(&self) -> &'static str {
        match self {
            CalibrateStep::TactileTare { .. } => "tare",
            CalibrateStep::TactileLoad { .. } => "load",
            CalibrateStep::TissueTouch { .. } | CalibrateStep::PivotTouch { .. } => "touch",
            CalibrateStep::JointsHome { .. } => "home",
            CalibrateStep::JointsSweep { .. } => "sweep",
        }
    }

    pub fn duration_s(&self) -> Option<f64> {
        match self {
            CalibrateStep::TactileTare { duration_s }
            | CalibrateStep::TactileLoad { duration_s, .. } => *duration_s,
            CalibrateStep::TissueTouch { .. }
            | CalibrateStep::PivotTouch { .. }
            | CalibrateStep::JointsHome { .. }
            | CalibrateStep::JointsSweep { .. } => None,
        }
    }

    /// The step moves the arm (and so needs it powered and nothing else moving it).
    pub fn moves_arm(&self) -> bool {
        matches!(
            self,
            CalibrateStep::TissueTouch { .. } | CalibrateStep::PivotTouch { .. }
        )
    }
}

impl Verb {
    pub fn name(&self) -> &'static str {
        match self {
            Verb::Status => "status",
            Verb::Enable => "enable",
            Verb::Disable => "disable",
            Verb::Home => "home",
            Verb::Jog { .. } => "jog",
            Verb::Move { .. } => "move",
            Verb::Mark => "mark",
            Verb::Track { .. } => "track",
            Verb::Pause => "pause",
            Verb::Resume => "resume",
            Verb::Stop => "stop",
            Verb::Estop => "estop",
            Verb::Reset => "reset",
            Verb::Subscribe { .. } => "subscribe",
            Verb::Unsubscribe => "unsubscribe",
            Verb::Calibrate(_) => "calibrate",
            Verb::Search { .. } => "search",
            Verb::Debug(_) => "debug",
        }
    }
}

impl Verb {
    /// The verb's arguments as parsed and range-checked, as JSON (SI units), for recording.
    pub fn args(&self) -> Map<String, Value> {
        let mut m = Map::new();
        let mut put = |k: &str, v: Value| {
            m.insert(k.to_string(), v);
        };
        match self {
            Verb::Jog { dx_m, dz_m } => {
                put("dx_m", (*dx_m).into());
                put("dz_m", (*dz_m).into());
            }
            Verb::Move {
                x_m,
                z_m,
                speed_m_s,
            } => {
                put("x_m", (*x_m).into());
                put("z_m", (*z_m).into());
                put("speed_m_s", (*speed_m_s).into());
            }
            Verb::Track { length_m, label } => {
                put("length_m", (*length_m).into());
                put("label", label.clone().into());
            }
            Verb::Subscribe {
                streams,
                tactile_every,
            } => {
                put("streams", serde_json::to_value(streams).unwrap_or_default());
                put("tactile_every", (*tactile_every).into());
            }
            Verb::Debug(DebugAction::SilenceTactile { duration_s }) => {
                put("action", "silence_tactile".into());
                put("duration_s", (*duration_s).into());
            }
            Verb::Debug(DebugAction::PlaceArray { load_per_element_n }) => {
                put("action", "place_array".into());
                put(
                    "on",
                    if load_per_element_n.is_some() {
                        "bench"
                    } else {
                        "tissue"
                    }
                    .into(),
                );
                put("load_per_element_n", (*load_per_element_n).into());
            }
            Verb::Calibrate(c) => {
                put("procedure", c.procedure().into());
                put("step", c.step().into());
                put("duration_s", c.duration_s().into());
                if let CalibrateStep::TactileLoad {
                    load_per_element_n, ..
                } = c
                {
                    put("load_per_element_n", (*load_per_element_n).into());
                }
                if let CalibrateStep::TissueTouch {
                    points,
                    course,
                    course_lateral_m,
                } = c
                {
                    put("course_lateral_m", (*course_lateral_m).into());
                    let xz = |p: &control::frames::SurfacePoint| serde_json::json!([p.x_m, p.z_m]);
                    put("points_m", points.iter().map(xz).collect());
                    put(
                        "course_m",
                        course.map_or(Value::Null, |c| Value::Array(c.iter().map(xz).collect())),
                    );
                }
                if let CalibrateStep::JointsHome { instrument_out } = c {
                    put("instrument_out", (*instrument_out).into());
                }
                if let CalibrateStep::JointsSweep {
                    instrument_out,
                    joints,
                } = c
                {
                    put("instrument_out", (*instrument_out).into());
                    put("joints", joints.clone().into());
                }
                if let CalibrateStep::PivotTouch { points } = c {
                    let xz = |p: &control::frames::SurfacePoint| serde_json::json!([p.x_m, p.z_m]);
                    put("points_m", points.iter().map(xz).collect());
                }
            }
            Verb::Search {
                region,
                method,
                heading_rad,
            } => {
                put("heading_rad", (*heading_rad).into());
                put("x0_m", region.x0_m.into());
                put("z0_m", region.z0_m.into());
                put("x1_m", region.x1_m.into());
                put("z1_m", region.z1_m.into());
                put("method", method.as_str().into());
            }
            Verb::Status
            | Verb::Enable
            | Verb::Disable
            | Verb::Home
            | Verb::Mark
            | Verb::Pause
            | Verb::Resume
            | Verb::Stop
            | Verb::Estop
            | Verb::Reset
            | Verb::Unsubscribe => {}
        }
        m
    }
}

/// The longest trial label, bytes.
pub const MAX_LABEL_BYTES: usize = 256;

/// A label is one line of printable text: it ends up in file metadata and summaries.
fn check_label(id: u64, label: &str) -> Result<(), RequestError> {
    if label.len() > MAX_LABEL_BYTES {
        return Err(err(
            Some(id),
            ErrorCode::OutOfRange,
            format!(
                "`label` is {} bytes; the limit is {MAX_LABEL_BYTES}",
                label.len()
            ),
        ));
    }
    if let Some(c) = label.chars().find(|c| c.is_control()) {
        return Err(err(
            Some(id),
            ErrorCode::BadArgument,
            format!("`label` must be one line of text without control characters (found {c:?})"),
        ));
    }
    Ok(())
}

/// Every verb the daemon knows, for error messages and the CLI.
pub const VERBS: [&str; 18] = [
    "status",
    "enable",
    "disable",
    "home",
    "jog",
    "move",
    "mark",
    "track",
    "pause",
    "resume",
    "stop",
    "estop",
    "reset",
    "subscribe",
    "unsubscribe",
    "calibrate",
    "search",
    "debug",
];

/// Error codes of `ok: false` replies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// Not a JSON object, or not valid JSON, or not UTF-8.
    Malformed,
    /// Longer than `console.max_line_bytes`.
    LineTooLong,
    /// No such verb.
    UnknownVerb,
    /// A missing, unknown or mistyped argument.
    BadArgument,
    /// A number outside its allowed range (or not finite).
    OutOfRange,
    /// The verb is not accepted in the current operating state.
    WrongState,
    /// The control loop refused (unreachable target, a cause still present).
    Refused,
    /// Too many requests: slow down.
    Flood,
    /// The daemon is shutting down or a part of it did not answer.
    Unavailable,
    /// What the reply would acknowledge could not be written to the trial recording (the
    /// reason names the file and the OS error); the trial was stopped.
    RecordingFailed,
}

/// A request that could not be turned into a verb.
#[derive(Debug, Clone, PartialEq)]
pub struct RequestError {
    pub id: Option<u64>,
    pub code: ErrorCode,
    pub reason: String,
}

/// A parsed request line.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    pub id: u64,
    pub verb: Verb,
}

fn err(id: Option<u64>, code: ErrorCode, reason: impl Into<String>) -> RequestError {
    RequestError {
        id,
        code,
        reason: reason.into(),
    }
}

/// Limits applied while parsing (from config).
#[derive(Debug, Clone, Copy)]
pub struct ParseLimits {
    pub max_jog_m: f64,
    pub max_speed_m_s: f64,
    /// Largest magnitude of a coordinate, m (anything beyond is nonsense for a tissue frame;
    /// the workspace check comes later, with the state).
    pub max_coordinate_m: f64,
    pub max_track_length_m: f64,
}

/// Parse one request line (without its newline).
pub fn parse_request(line: &[u8], limits: &ParseLimits) -> Result<Request, RequestError> {
    let text = std::str::from_utf8(line)
        .map_err(|e| err(None, ErrorCode::Malformed, format!("not UTF-8: {e}")))?;
    let value: Value = serde_json::from_str(text).map_err(|e| {
        err(
            None,
            ErrorCode::Malformed,
            format!("not JSON: {e} (one JSON object per line)"),
        )
    })?;
    let Value::Object(mut obj) = value else {
        return Err(err(
            None,
            ErrorCode::Malformed,
            "a request must be a JSON object",
        ));
    };
    let id = match obj.remove("id") {
        Some(Value::Number(n)) => n.as_u64().ok_or_else(|| {
            err(
                None,
                ErrorCode::BadArgument,
                "`id` must be a non-negative integer",
            )
        })?,
        Some(_) => {
            return Err(err(
                None,
                ErrorCode::BadArgument,
                "`id` must be a non-negative integer",
            ));
        }
        None => return Err(err(None, ErrorCode::BadArgument, "missing `id`")),
    };
    let verb_name = match obj.remove("verb") {
        Some(Value::String(s)) => s,
        Some(_) => {
            return Err(err(
                Some(id),
                ErrorCode::BadArgument,
                "`verb` must be a string",
            ));
        }
        None => return Err(err(Some(id), ErrorCode::BadArgument, "missing `verb`")),
    };
    let mut args = Args {
        id,
        verb: verb_name.clone(),
        obj,
    };
    let verb = match verb_name.as_str() {
        "status" => Verb::Status,
        "enable" => Verb::Enable,
        "disable" => Verb::Disable,
        "home" => Verb::Home,
        "mark" => Verb::Mark,
        "pause" => Verb::Pause,
        "resume" => Verb::Resume,
        "stop" => Verb::Stop,
        "estop" => Verb::Estop,
        "reset" => Verb::Reset,
        "unsubscribe" => Verb::Unsubscribe,
        "jog" => {
            let dx_m = args.number("dx_m", Some(0.0))?;
            let dz_m = args.number("dz_m", Some(0.0))?;
            let len = dx_m.hypot(dz_m);
            if len > limits.max_jog_m {
                return Err(err(
                    Some(id),
                    ErrorCode::OutOfRange,
                    format!(
                        "jog of {len:.6} m exceeds the largest jog, {} m",
                        limits.max_jog_m
                    ),
                ));
            }
            Verb::Jog { dx_m, dz_m }
        }
        "move" => {
            let x_m = args.number("x_m", None)?;
            let z_m = args.number("z_m", None)?;
            for (name, v) in [("x_m", x_m), ("z_m", z_m)] {
                if v.abs() > limits.max_coordinate_m {
                    return Err(err(
                        Some(id),
                        ErrorCode::OutOfRange,
                        format!("`{name}` = {v} m is beyond ±{} m", limits.max_coordinate_m),
                    ));
                }
            }
            let speed_m_s = args.optional_number("speed_m_s")?;
            if let Some(s) = speed_m_s
                && !(s > 0.0 && s <= limits.max_speed_m_s)
            {
                return Err(err(
                    Some(id),
                    ErrorCode::OutOfRange,
                    format!(
                        "`speed_m_s` = {s} must be in (0, {}] m/s",
                        limits.max_speed_m_s
                    ),
                ));
            }
            Verb::Move {
                x_m,
                z_m,
                speed_m_s,
            }
        }
        "track" => {
            let length_m = args.optional_number("length_m")?;
            if let Some(l) = length_m
                && !(l > 0.0 && l <= limits.max_track_length_m)
            {
                return Err(err(
                    Some(id),
                    ErrorCode::OutOfRange,
                    format!(
                        "`length_m` = {l} must be in (0, {}] m (omit it to track until the artery is lost)",
                        limits.max_track_length_m
                    ),
                ));
            }
            let label = match args.obj.remove("label") {
                None | Some(Value::Null) => None,
                Some(Value::String(l)) => {
                    check_label(id, &l)?;
                    Some(l)
                }
                Some(other) => {
                    return Err(err(
                        Some(id),
                        ErrorCode::BadArgument,
                        format!("`label` must be a string, got {other}"),
                    ));
                }
            };
            Verb::Track { length_m, label }
        }
        "calibrate" => Verb::Calibrate(calibrate_request::parse(&mut args, limits)?),
        "search" => search_request::parse(&mut args, limits)?,
        "subscribe" => {
            let streams = match args.obj.remove("streams") {
                None => Stream::ALL.to_vec(),
                Some(v) => serde_json::from_value::<Vec<Stream>>(v).map_err(|e| {
                    err(
                        Some(id),
                        ErrorCode::BadArgument,
                        format!(
                            "`streams` must be a list of state, tactile, detections, faults, trials, calibration, search: {e}"
                        ),
                    )
                })?,
            };
            let every = args.optional_number("tactile_every")?.unwrap_or(1.0);
            if !((1.0..=10_000.0).contains(&every) && every.fract() == 0.0) {
                return Err(err(
                    Some(id),
                    ErrorCode::OutOfRange,
                    format!("`tactile_every` = {every} must be a whole number from 1 to 10000"),
                ));
            }
            Verb::Subscribe {
                streams,
                tactile_every: every as u32,
            }
        }
        "debug" => {
            let action = match args.obj.remove("action") {
                Some(Value::String(s)) => s,
                _ => {
                    return Err(err(
                        Some(id),
                        ErrorCode::BadArgument,
                        "`debug` needs `action`: \"silence_tactile\" or \"place_array\"",
                    ));
                }
            };
            match action.as_str() {
                "place_array" => Verb::Debug(calibrate_request::place_array(&mut args)?),
                "silence_tactile" => {
                    let d = args.number("duration_s", None)?;
                    if !(d > 0.0 && d <= 3600.0) {
                        return Err(err(
                            Some(id),
                            ErrorCode::OutOfRange,
                            format!("`duration_s` = {d} must be in (0, 3600] s"),
                        ));
                    }
                    Verb::Debug(DebugAction::SilenceTactile { duration_s: d })
                }
                other => {
                    return Err(err(
                        Some(id),
                        ErrorCode::BadArgument,
                        format!(
                            "unknown debug action {other:?} (known: silence_tactile, place_array)"
                        ),
                    ));
                }
            }
        }
        other => {
            return Err(err(
                Some(id),
                ErrorCode::UnknownVerb,
                format!("unknown verb {other:?}; known verbs: {}", VERBS.join(", ")),
            ));
        }
    };
    args.no_more()?;
    Ok(Request { id, verb })
}

#[path = "calibrate_request.rs"]
mod calibrate_request;
#[path = "search_request.rs"]
mod search_request;

struct Args {
    id: u64,
    verb: String,
    obj: Map<String, Value>,
}

impl Args {
    fn optional_number(&mut self, name: &str) -> Result<Option<f64>, RequestError> {
        match self.obj.remove(name) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::Number(n)) => {
                let v = n.as_f64().unwrap_or(f64::NAN);
                if v.is_finite() {
                    Ok(Some(v))
                } else {
                    Err(err(
                        Some(self.id),
                        ErrorCode::OutOfRange,
                        format!("`{name}` must be a finite number"),
                    ))
                }
            }
            Some(other) => Err(err(
                Some(self.id),
                ErrorCode::BadArgument,
                format!("`{name}` must be a number, got {other}"),
            )),
        }
    }

    fn number(&mut self, name: &str, default: Option<f64>) -> Result<f64, RequestError> {
        match (self.optional_number(name)?, default) {
            (Some(v), _) => Ok(v),
            (None, Some(d)) => Ok(d),
            (None, None) => Err(err(
                Some(self.id),
                ErrorCode::BadArgument,
                format!("`{}` needs `{name}`", self.verb),
            )),
        }
    }

    fn no_more(&self) -> Result<(), RequestError> {
        if let Some(k) = self.obj.keys().next() {
            return Err(err(
                Some(self.id),
                ErrorCode::BadArgument,
                format!("`{}` takes no argument `{k}`", self.verb),
            ));
        }
        Ok(())
    }
}

/// A reply line.
pub fn ok_reply(id: u64, result: Value) -> Value {
    let mut obj = Map::new();
    obj.insert("id".into(), Value::from(id));
    obj.insert("ok".into(), Value::Bool(true));
    if let Value::Object(r) = result {
        for (k, v) in r {
            if k != "id" && k != "ok" {
                obj.insert(k, v);
            }
        }
    }
    Value::Object(obj)
}

pub fn error_reply(id: Option<u64>, code: ErrorCode, reason: &str) -> Value {
    serde_json::json!({
        "id": id,
        "ok": false,
        "error": code,
        "reason": reason,
    })
}

/// The first line the server sends.
pub fn hello(daemon_version: &str, state: &str, backend: &str) -> Value {
    serde_json::json!({
        "hello": "pulsetrackd",
        "protocol": PROTOCOL_VERSION,
        "version": daemon_version,
        "state": state,
        "backend": backend,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: ParseLimits = ParseLimits {
        max_jog_m: 0.01,
        max_speed_m_s: 0.03,
        max_coordinate_m: 1.0,
        max_track_length_m: 2.0,
    };

    fn parse(s: &str) -> Result<Request, RequestError> {
        parse_request(s.as_bytes(), &LIMITS)
    }

    #[test]
    fn verbs_with_arguments() {
        assert_eq!(
            parse(r#"{"id":3,"verb":"move","x_m":0.01,"z_m":-0.002}"#)
                .expect("move")
                .verb,
            Verb::Move {
                x_m: 0.01,
                z_m: -0.002,
                speed_m_s: None
            }
        );
        assert_eq!(
            parse(r#"{"id":4,"verb":"track"}"#).expect("track").verb,
            Verb::Track {
                length_m: None,
                label: None
            }
        );
        let track = parse(r#"{"id":4,"verb":"track","length_m":0.1,"label":"pig 3, left"}"#)
            .expect("track")
            .verb;
        assert_eq!(
            track,
            Verb::Track {
                length_m: Some(0.1),
                label: Some("pig 3, left".into())
            }
        );
        assert_eq!(
            serde_json::Value::Object(track.args()),
            serde_json::json!({"length_m": 0.1, "label": "pig 3, left"})
        );
        assert_eq!(
            serde_json::Value::Object(
                parse(r#"{"id":3,"verb":"move","x_m":0.01,"z_m":-0.002}"#)
                    .expect("move")
                    .verb
                    .args()
            ),
            serde_json::json!({"x_m": 0.01, "z_m": -0.002, "speed_m_s": null})
        );
        assert_eq!(
            parse(r#"{"id":5,"verb":"subscribe","streams":["tactile"],"tactile_every":10}"#)
                .expect("sub")
                .verb,
            Verb::Subscribe {
                streams: vec![Stream::Tactile],
                tactile_every: 10
            }
        );
        assert_eq!(
            parse(r#"{"id":6,"verb":"jog","dx_m":0.001}"#)
                .expect("jog")
                .verb,
            Verb::Jog {
                dx_m: 0.001,
                dz_m: 0.0
            }
        );
    }

    #[test]
    fn every_kind_of_bad_line_gets_a_code() {
        let cases: [(&str, ErrorCode, Option<u64>); 11] = [
            ("not json", ErrorCode::Malformed, None),
            ("[1,2]", ErrorCode::Malformed, None),
            (r#"{"verb":"status"}"#, ErrorCode::BadArgument, None),
            (r#"{"id":-1,"verb":"status"}"#, ErrorCode::BadArgument, None),
            (r#"{"id":1}"#, ErrorCode::BadArgument, Some(1)),
            (r#"{"id":1,"verb":"fly"}"#, ErrorCode::UnknownVerb, Some(1)),
            (
                r#"{"id":1,"verb":"move","x_m":0.0}"#,
                ErrorCode::BadArgument,
                Some(1),
            ),
            (
                r#"{"id":1,"verb":"move","x_m":"a","z_m":0}"#,
                ErrorCode::BadArgument,
                Some(1),
            ),
            (
                r#"{"id":1,"verb":"move","x_m":5.0,"z_m":0}"#,
                ErrorCode::OutOfRange,
                Some(1),
            ),
            (
                r#"{"id":1,"verb":"jog","dx_m":0.5}"#,
                ErrorCode::OutOfRange,
                Some(1),
            ),
            (
                r#"{"id":1,"verb":"status","extra":1}"#,
                ErrorCode::BadArgument,
                Some(1),
            ),
        ];
        for (line, code, id) in cases {
            let e = parse(line).expect_err(line);
            assert_eq!((e.code, e.id), (code, id), "{line}: {}", e.reason);
            assert!(!e.reason.is_empty());
        }
        let e = parse_request(&[0xff, 0xfe], &LIMITS).expect_err("utf8");
        assert_eq!(e.code, ErrorCode::Malformed);
        let e = parse(r#"{"id":1,"verb":"track","label":3}"#).expect_err("label type");
        assert_eq!(e.code, ErrorCode::BadArgument);
        let e = parse(r#"{"id":1,"verb":"track","label":"a\nb"}"#).expect_err("newline");
        assert!(
            e.code == ErrorCode::BadArgument && e.reason.contains("label"),
            "{e:?}"
        );
        let long = format!(r#"{{"id":1,"verb":"track","label":"{}"}}"#, "x".repeat(300));
        let e = parse(&long).expect_err("long");
        assert!(
            e.code == ErrorCode::OutOfRange && e.reason.contains("256"),
            "{e:?}"
        );
        let e = parse(r#"{"id":1,"verb":"track","length_m":-1}"#).expect_err("neg");
        assert_eq!(e.code, ErrorCode::OutOfRange);
        let e = parse(r#"{"id":1,"verb":"move","x_m":1e999,"z_m":0}"#).expect_err("inf");
        assert!(matches!(
            e.code,
            ErrorCode::OutOfRange | ErrorCode::Malformed
        ));
    }

    #[test]
    fn replies_have_id_ok_and_reason() {
        let r = error_reply(
            Some(7),
            ErrorCode::WrongState,
            "cannot track while disabled",
        );
        assert_eq!(r["id"], 7);
        assert_eq!(r["ok"], false);
        assert_eq!(r["error"], "wrong_state");
        let r = ok_reply(8, serde_json::json!({"state": "holding", "ok": "spoof"}));
        assert_eq!(r["ok"], true);
        assert_eq!(r["state"], "holding");
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..200)) {
            let _ = parse_request(&bytes, &LIMITS);
        }

        #[test]
        fn arbitrary_json_objects_never_panic(id in 0u64..1000, verb in "[a-z]{0,12}", x in proptest::num::f64::ANY) {
            let line = serde_json::json!({"id": id, "verb": verb, "x_m": x, "z_m": x, "dx_m": x}).to_string();
            let _ = parse_request(line.as_bytes(), &LIMITS);
        }
    }
}
