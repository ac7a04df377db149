//! Offline replay: a recorded trial's tactile frames, believed sensor positions and settled
//! flags, and the calls made into its tracker (mark, start, stop, target unreachable), fed in
//! recorded order to a tracker built by `control::tracker::build`. With the tracker that
//! recorded the trial it reproduces the recorded located points bit for bit; with another it
//! shows what that tracker would have reported on the same data (the sensor still moves as
//! the recording's tracker moved it). This is how trackers are compared on rig recordings,
//! where no simulator knows the truth.

use control::frames::SurfacePoint;
use control::tracker::{
    LocatedPoint, TrackLimit, Tracker, TrackerEvent, TrackerInput, TrackerParams,
};
use control::types::TactileFrame;
use serde::Serialize;
use serde_json::Value;

use crate::recording::messages::{TactileSample, TrackerCall, TrackerInputRecord};
use crate::recording::recover::ReadBack;
use crate::recording::topics::Topic;
use control::calibration::TactileCalibration;

/// One input to the tracker, in recorded order.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    Frame {
        frame: TactileFrame,
        sensor: SurfacePoint,
        settled: bool,
        /// Where the arm's load put the sensor, if recorded.
        loaded_sensor: Option<SurfacePoint>,
    },
    Call(TrackerCall),
}

/// What a recording holds for replay.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    pub steps: Vec<Step>,
    /// The tracker that ran live, from the trial metadata.
    pub tracker: Option<String>,
    /// Its parameters and the array geometry, from the resolved configuration recorded.
    pub config: Option<config::Config>,
    /// The located points the live tracker reported, in order.
    pub located: Vec<Located>,
    /// The tactile calibration in use live (the frames in `steps` are already corrected by
    /// it; trackers are built with its unusable elements skipped).
    pub tactile_calibration: Option<TactileCalibration>,
    /// Frames missing between two frames given to the tracker (a lagging recorder drops
    /// streamed samples rather than stall); a replay with gaps may differ from the trial.
    pub missing_frames: u64,
}

/// A located point, as recorded and as replayed (the fields the tracker produces).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Located {
    pub t_s: f64,
    pub x_m: f64,
    pub z_m: f64,
    pub sensor_x_m: f64,
    pub sensor_z_m: f64,
    pub element: f64,
    pub amplitude_n: f64,
    pub seed: bool,
    /// The point's uncertainty across the artery (one SD), m; absent from trackers that
    /// give none and from recordings made before it was recorded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sd_m: Option<f64>,
}

impl From<&LocatedPoint> for Located {
    fn from(p: &LocatedPoint) -> Self {
        Located {
            t_s: p.t_s,
            x_m: p.point.x_m,
            z_m: p.point.z_m,
            sensor_x_m: p.sensor.x_m,
            sensor_z_m: p.sensor.z_m,
            element: p.element,
            amplitude_n: p.amplitude_n,
            seed: p.seed,
            sd_m: p.sd_m,
        }
    }
}

impl Located {
    /// Equal to the last bit in every number (NaN equal to the same NaN); the SD only
    /// where both have one.
    pub fn same_bits(&self, o: &Located) -> bool {
        let b = |a: f64, b: f64| a.to_bits() == b.to_bits();
        b(self.t_s, o.t_s)
            && b(self.x_m, o.x_m)
            && b(self.z_m, o.z_m)
            && b(self.sensor_x_m, o.sensor_x_m)
            && b(self.sensor_z_m, o.sensor_z_m)
            && b(self.element, o.element)
            && b(self.amplitude_n, o.amplitude_n)
            && self.seed == o.seed
            // Recordings made before points carried an SD have none to compare.
            && match (self.sd_m, o.sd_m) {
                (Some(x), Some(y)) => b(x, y),
                _ => true,
            }
    }

    fn from_recorded(v: &Value) -> Option<Located> {
        let f = |k: &str| v.get(k).and_then(Value::as_f64);
        Some(Located {
            t_s: f("t_s")?,
            x_m: f("x_m")?,
            z_m: f("z_m")?,
            sensor_x_m: f("sensor_x_m")?,
            sensor_z_m: f("sensor_z_m")?,
            element: f("element")?,
            amplitude_n: f("amplitude_n")?,
            seed: v.get("seed").and_then(Value::as_bool)?,
            sd_m: f("sd_m"),
        })
    }
}

/// Why a recording cannot be replayed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReplayError {
    #[error(
        "the recording has no tracker inputs (frames marked as given to the tracker, mark and track calls): it was recorded before offline replay existed, or no trial ran in it (a search's own recording)"
    )]
    NoTrackerInputs,
    #[error("{topic} message {index}: {reason}")]
    BadMessage {
        topic: &'static str,
        index: usize,
        reason: String,
    },
}

/// Collect the replay inputs of a recording, in file order (the order the supervisor gave
/// them to the tracker).
pub fn recorded(back: &ReadBack) -> Result<Recorded, ReplayError> {
    let mut steps = Vec::new();
    let mut located = Vec::new();
    let mut missing_frames = 0u64;
    let mut last_seq: Option<u64> = None;
    for (index, m) in back.messages.iter().enumerate() {
        if m.topic == Topic::Tactile.name() {
            let s: TactileSample =
                serde_json::from_slice(&m.data).map_err(|e| ReplayError::BadMessage {
                    topic: "/tactile",
                    index,
                    reason: e.to_string(),
                })?;
            let Some(settled) = s.tracker_settled else {
                last_seq = None;
                continue;
            };
            if let Some(prev) = last_seq {
                missing_frames += s.seq.saturating_sub(prev).saturating_sub(1);
            }
            last_seq = Some(s.seq);
            steps.push(Step::Frame {
                frame: TactileFrame {
                    t_s: s.t_s,
                    seq: s.seq,
                    force_n: s.force_n,
                },
                sensor: SurfacePoint::new(
                    s.sensor_x_m.unwrap_or(f64::NAN),
                    s.sensor_z_m.unwrap_or(f64::NAN),
                ),
                settled,
                loaded_sensor: match (s.loaded_x_m, s.loaded_z_m) {
                    (Some(x), Some(z)) => Some(SurfacePoint::new(x, z)),
                    _ => None,
                },
            });
        } else if m.topic == Topic::Events.name() {
            match m.json.get("event").and_then(Value::as_str) {
                Some("tracker_input") => {
                    let r: TrackerInputRecord =
                        serde_json::from_slice(&m.data).map_err(|e| ReplayError::BadMessage {
                            topic: "/events",
                            index,
                            reason: e.to_string(),
                        })?;
                    steps.push(Step::Call(r.call));
                }
                Some("detection") if m.json["kind"] == "located" => {
                    let p = Located::from_recorded(&m.json["point"]).ok_or_else(|| {
                        ReplayError::BadMessage {
                            topic: "/events",
                            index,
                            reason: "a located point without its numbers".into(),
                        }
                    })?;
                    located.push(p);
                }
                _ => {}
            }
        }
    }
    if steps.is_empty() {
        return Err(ReplayError::NoTrackerInputs);
    }
    let trial = back.metadata_named("trial");
    let tracker = trial.and_then(|t| t.get("tracker")).cloned();
    // The tactile calibration the live tracker read the array through: replay feeds the
    // frames through it too (a trial from before calibrations has none).
    let tactile_calibration = match trial.and_then(|t| t.get("tactile_calibration")) {
        None => None,
        Some(j) => {
            let c: TactileCalibration =
                serde_json::from_str(j).map_err(|e| ReplayError::BadMessage {
                    topic: "metadata trial",
                    index: 0,
                    reason: format!("tactile_calibration: {e}"),
                })?;
            c.validate().map_err(|e| ReplayError::BadMessage {
                topic: "metadata trial",
                index: 0,
                reason: format!("tactile_calibration: {e}"),
            })?;
            for step in &mut steps {
                if let Step::Frame { frame, .. } = step {
                    *frame = c.correct_frame(frame);
                }
            }
            Some(c)
        }
    };
    let config = back
        .metadata_named("config")
        .and_then(|c| c.get("json"))
        .and_then(|j| serde_json::from_str::<config::Config>(j).ok());
    Ok(Recorded {
        steps,
        tracker,
        config,
        located,
        missing_frames,
        tactile_calibration,
    })
}

/// What the tracker said on replay.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Replayed {
    pub located: Vec<Located>,
    /// Every event, as JSON (`kind`, `t_s`, ...), in order.
    pub events: Vec<Value>,
    /// Calls the tracker refused, with its words (as it refused them live, if it is the
    /// recording's tracker).
    pub refused: Vec<String>,
    pub frames: u64,
}

/// Feed `steps` to `tracker`.
pub fn replay(steps: &[Step], tracker: &mut dyn Tracker) -> Replayed {
    let mut out = Replayed::default();
    for step in steps {
        match step {
            Step::Frame {
                frame,
                sensor,
                settled,
                loaded_sensor,
            } => {
                out.frames += 1;
                let o = tracker.step(&TrackerInput {
                    frame,
                    sensor: *sensor,
                    settled: *settled,
                    loaded_sensor: *loaded_sensor,
                });
                if let Some(e) = o.event {
                    if let TrackerEvent::Located(p) = e {
                        out.located.push(Located::from(&p));
                    }
                    out.events.push(event_json(&e));
                }
            }
            Step::Call(call) => {
                let r = match call {
                    TrackerCall::Mark => tracker.mark(),
                    TrackerCall::Start { length_m } => tracker.start(TrackLimit {
                        length_m: *length_m,
                    }),
                    TrackerCall::Stop => {
                        tracker.stop();
                        Ok(())
                    }
                    TrackerCall::TargetUnreachable => {
                        tracker.target_unreachable();
                        Ok(())
                    }
                    TrackerCall::Approach { x_m, z_m } => {
                        tracker.approach(SurfacePoint::new(*x_m, *z_m));
                        Ok(())
                    }
                };
                if let Err(e) = r {
                    out.refused.push(format!("{call:?}: {e}"));
                }
            }
        }
    }
    out
}

/// A listen's progress as its event's JSON (`kind` "listening").
pub(crate) fn listening_json(p: &control::tracker::ListenProgress) -> Value {
    let mut v = serde_json::to_value(p).unwrap_or_default();
    v["kind"] = "listening".into();
    v
}

fn event_json(e: &TrackerEvent) -> Value {
    use serde_json::json;
    match e {
        TrackerEvent::Located(p) => json!({"kind": "located", "t_s": p.t_s,
            "x_m": p.point.x_m, "z_m": p.point.z_m, "element": p.element,
            "amplitude_n": p.amplitude_n, "seed": p.seed, "sd_m": p.sd_m}),
        TrackerEvent::Missed { t_s, at } => {
            json!({"kind": "missed", "t_s": t_s, "x_m": at.x_m, "z_m": at.z_m})
        }
        TrackerEvent::Backtracking { t_s, toward } => {
            json!({"kind": "backtracking", "t_s": t_s, "x_m": toward.x_m, "z_m": toward.z_m})
        }
        TrackerEvent::Pulse { t_s, period_s } => {
            json!({"kind": "pulse", "t_s": t_s, "period_s": period_s})
        }
        TrackerEvent::Finished { t_s, reason } => {
            json!({"kind": "finished", "t_s": t_s, "reason": reason.as_str()})
        }
        TrackerEvent::Listening(p) => listening_json(p),
    }
}

/// Build `name` with the recording's tracker parameters and array geometry (or `fallback`
/// when the recording holds no configuration), and replay the recording through it.
pub fn replay_with(
    rec: &Recorded,
    name: &str,
    fallback: &config::Config,
) -> Result<Replayed, String> {
    let c = rec.config.as_ref().unwrap_or(fallback);
    let params: TrackerParams = c.tracker.params;
    let sensor = match &rec.tactile_calibration {
        Some(cal) => cal
            .geometry(&c.sensor)
            .map_err(|e| format!("the recorded tactile calibration: {e}"))?,
        None => c.sensor,
    };
    let mut tracker = control::tracker::build(name, &params, &sensor).map_err(|e| e.to_string())?;
    Ok(replay(&rec.steps, tracker.as_mut()))
}

/// The index of the first located point that differs (or that only one side has).
pub fn first_difference(a: &[Located], b: &[Located]) -> Option<usize> {
    let n = a.len().max(b.len());
    (0..n).find(|&i| match (a.get(i), b.get(i)) {
        (Some(x), Some(y)) => !x.same_bits(y),
        _ => true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x_m: f64) -> Located {
        Located {
            t_s: 1.0,
            x_m,
            z_m: 0.0,
            sensor_x_m: 0.0,
            sensor_z_m: 0.0,
            element: 4.5,
            amplitude_n: 0.05,
            seed: false,
            sd_m: Some(3e-4),
        }
    }

    #[test]
    fn differences_are_found_to_the_last_bit_and_in_length() {
        let a = [p(0.01), p(0.02)];
        assert_eq!(first_difference(&a, &a), None);
        let nudged = [p(0.01), p(f64::from_bits(0.02f64.to_bits() + 1))];
        assert_eq!(first_difference(&a, &nudged), Some(1));
        assert_eq!(first_difference(&a, &a[..1]), Some(1));
        assert_eq!(first_difference(&[], &a), Some(0));
        assert!(p(f64::NAN).same_bits(&p(f64::NAN)));
        let sd = |sd_m| Located { sd_m, ..p(0.01) };
        assert!(!sd(Some(3e-4)).same_bits(&sd(Some(3.0001e-4))));
        // A recording from before points carried an SD still compares on the rest.
        assert!(sd(None).same_bits(&sd(Some(3e-4))));
    }

    #[test]
    fn a_recording_without_tracker_inputs_is_refused() {
        let fixture =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/v0-trial.mcap");
        let back = crate::recording::recover::read(&fixture).expect("fixture");
        assert_eq!(recorded(&back), Err(ReplayError::NoTrackerInputs));
    }
}
