//! JSON views of the daemon's state: recorded samples, state heartbeats, the status reply.

use std::path::PathBuf;

use serde_json::{Value, json};

use crate::backend::BackendInfo;
use crate::recording::messages::{JointSample, TactileSample, finite};
use crate::rt::fault::Fault;
use crate::rt::link::{ControlStatus, LoopMode, StampedFrame};
use crate::rt::period_stats::PeriodSummary;
use crate::supervisor::state::OpState;
use crate::supervisor::trial::Trial;

fn num(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

pub fn joint_sample(s: &ControlStatus, state: OpState) -> JointSample {
    JointSample {
        t_s: s.t_s,
        state: state.as_str().to_string(),
        position_rad: s.position_rad,
        velocity_rad_s: s.velocity_rad_s,
        setpoint_rad: s.setpoint_rad,
        torque_nm: s.torque_nm,
        sensor_x_m: finite(s.sensor.x_m),
        sensor_z_m: finite(s.sensor.z_m),
        setpoint_x_m: finite(s.setpoint.x_m),
        setpoint_z_m: finite(s.setpoint.z_m),
        depth_m: finite(s.depth_m),
        contact_n: finite(s.contact_n),
    }
}

/// A frame as recorded and streamed; `tracker_settled` is what the trial's tracker was told
/// with it (`None`: not given to a tracker).
pub fn tactile_sample(f: &StampedFrame, tracker_settled: Option<bool>) -> TactileSample {
    TactileSample {
        t_s: f.frame.t_s,
        seq: f.frame.seq,
        force_n: f.frame.force_n,
        sensor_x_m: finite(f.sensor.x_m),
        sensor_z_m: finite(f.sensor.z_m),
        settled: f.settled,
        contact_n: finite(f.contact_n),
        tracker_settled,
        loaded_x_m: f.loaded_sensor.and_then(|s| finite(s.x_m)),
        loaded_z_m: f.loaded_sensor.and_then(|s| finite(s.z_m)),
    }
}

pub fn state_beat(s: &ControlStatus, state: OpState, trial: Option<&Trial>) -> Value {
    json!({
        "event": "state",
        "t_s": s.t_s,
        "state": state.as_str(),
        "sensor_x_m": num(s.sensor.x_m),
        "sensor_z_m": num(s.sensor.z_m),
        "contact_n": num(s.contact_n),
        "seeds": trial.map(|t| t.seeds()).unwrap_or(0),
        "located": trial.map(|t| t.located.len()).unwrap_or(0),
        "followed_m": trial.map(|t| t.followed_m()).unwrap_or(0.0),
    })
}

#[allow(clippy::too_many_arguments)]
pub fn status_json(
    s: ControlStatus,
    fault: Option<&(Fault, Option<PathBuf>)>,
    info: &BackendInfo,
    trial: Option<&Trial>,
    last_trial: Option<&Value>,
    timing: Option<PeriodSummary>,
    frames_seen: u64,
) -> Value {
    let mode = match s.mode {
        LoopMode::Disabled => "disabled",
        LoopMode::Enabled => "enabled",
        LoopMode::Faulted => "faulted",
    };
    json!({
        "t_s": s.t_s,
        "fault": fault.map(|(f, dump)| json!({
            "fault": f.kind, "reason": f.describe(), "t_s": f.t_s, "flight_recorder": dump,
        })),
        "backend": info,
        "arm": {
            "mode": mode,
            "position_rad": s.position_rad,
            "velocity_rad_s": s.velocity_rad_s,
            "torque_nm": s.torque_nm,
            "sensor": {"x_m": num(s.sensor.x_m), "z_m": num(s.sensor.z_m)},
            "setpoint": {"x_m": num(s.setpoint.x_m), "z_m": num(s.setpoint.z_m)},
            "depth_m": num(s.depth_m),
            "settled": s.settled,
        },
        "tactile": {
            "t_s": num(s.tactile_t_s),
            "age_s": num(s.t_s - s.tactile_t_s),
            "contact_n": num(s.contact_n),
            "frames": s.tactile_frames,
            "frames_supervised": frames_seen,
        },
        "trial": trial.map(|t| json!({
            "trial": t.id,
            "tracker": t.tracker,
            "seeds": t.seeds(),
            "located": t.located.len(),
            "followed_m": t.followed_m(),
            "backtracks": t.backtracks,
            "tracking": t.track_started_t_s.is_some(),
        })),
        "last_trial": last_trial,
        "loop": {
            "cycles": s.cycle,
            "overruns": s.overruns,
            "dropped": s.dropped,
            "period": timing,
        },
    })
}
