//! One trial's bookkeeping: from the first mark to the end of tracking. Produces the
//! summary written beside the recording (and printed by `pulsetrack demo`).

use control::tracker::{EndReason, LocatedPoint};
use serde::Serialize;
use serde_json::{Value, json};

use crate::backend::{PathJudge, Truth};
use crate::recording::replay::Located;

/// A located point with what only the simulator knows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocatedRecord {
    /// What the tracker reported (the fields replay reproduces).
    #[serde(flatten)]
    pub point: Located,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub true_x_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub true_z_m: Option<f64>,
    /// Signed lateral offset from the true path, m (sim only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lateral_error_m: Option<f64>,
}

/// Why a trial ended, beyond the tracker's own reasons.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrialEnd {
    Tracker(EndReason),
    Fault,
    Disabled,
    Shutdown,
    /// Abandoned before tracking started (stop during a mark, or a new trial begun).
    Abandoned,
    /// The recording could not be written, so the trial could not go on.
    RecordingFailed,
    /// The arm stopped short of a tracking target (judged from the encoders): no fix was
    /// taken there; the arm holds where it is.
    ShortOfTarget,
}

impl TrialEnd {
    pub fn as_str(&self) -> &'static str {
        match self {
            TrialEnd::Tracker(r) => r.as_str(),
            TrialEnd::Fault => "fault",
            TrialEnd::Disabled => "disabled",
            TrialEnd::Shutdown => "shutdown",
            TrialEnd::Abandoned => "abandoned",
            TrialEnd::RecordingFailed => "recording_failed",
            TrialEnd::ShortOfTarget => "short_of_target",
        }
    }
}

#[derive(Debug, Clone)]
pub struct Trial {
    pub id: String,
    pub tracker: String,
    /// Daemon time on the Unix epoch in this trial's recording (ns offset).
    pub epoch_offset_ns: i128,
    /// What the trial is, as given with `track`.
    pub label: Option<String>,
    pub started_t_s: f64,
    pub track_started_t_s: Option<f64>,
    pub length_m: Option<f64>,
    pub located: Vec<LocatedRecord>,
    pub backtracks: u32,
    pub misses: u32,
    pub pulse_period_s: Option<f64>,
}

impl Trial {
    pub fn new(id: String, tracker: String, t_s: f64, epoch_offset_ns: i128) -> Self {
        Self {
            id,
            tracker,
            epoch_offset_ns,
            label: None,
            started_t_s: t_s,
            track_started_t_s: None,
            length_m: None,
            located: Vec::new(),
            backtracks: 0,
            misses: 0,
            pulse_period_s: None,
        }
    }

    pub fn seeds(&self) -> usize {
        self.located.iter().filter(|p| p.point.seed).count()
    }

    pub fn add_located(
        &mut self,
        p: &LocatedPoint,
        truth: Option<Truth>,
        judge: Option<&dyn PathJudge>,
    ) -> LocatedRecord {
        let r = LocatedRecord {
            point: Located::from(p),
            true_x_m: truth.map(|t| t.sensor_x_m),
            true_z_m: truth.map(|t| t.sensor_z_m),
            lateral_error_m: judge.map(|j| j.lateral_offset_m(p.point.x_m, p.point.z_m)),
        };
        self.located.push(r);
        r
    }

    /// Path length along the located points, m.
    pub fn followed_m(&self) -> f64 {
        self.located
            .windows(2)
            .map(|w| (w[1].point.x_m - w[0].point.x_m).hypot(w[1].point.z_m - w[0].point.z_m))
            .sum()
    }

    /// The summary of a finished trial.
    pub fn summary(
        &self,
        end: TrialEnd,
        ended_t_s: f64,
        judge: Option<&dyn PathJudge>,
        recording: &str,
        extra: Value,
    ) -> Value {
        let duration_s = self
            .track_started_t_s
            .map(|t0| (ended_t_s - t0).max(0.0))
            .unwrap_or(0.0);
        let beats = match (judge, self.track_started_t_s) {
            (Some(j), Some(t0)) => Some(j.beats_between(t0, ended_t_s)),
            _ => self
                .pulse_period_s
                .filter(|p| *p > 0.0)
                .map(|p| duration_s / p),
        };
        let errors: Vec<f64> = self
            .located
            .iter()
            .filter(|p| !p.point.seed)
            .filter_map(|p| p.lateral_error_m)
            .collect();
        let lateral = error_stats(&errors);
        let completed = matches!(end, TrialEnd::Tracker(r) if r.is_completed());
        json!({
            "trial": self.id,
            "recording": recording,
            "tracker": self.tracker,
            "label": self.label,
            "started_t_s": self.started_t_s,
            "track_started_t_s": self.track_started_t_s,
            "ended_t_s": ended_t_s,
            "duration_s": duration_s,
            "beats": beats,
            "backtracks": self.backtracks,
            "misses": self.misses,
            "completed": completed,
            "end_reason": end.as_str(),
            "length_m": self.length_m,
            "followed_m": self.followed_m(),
            "pulse_period_s": self.pulse_period_s,
            "lateral_error_m": lateral,
            "located": self.located,
            "context": extra,
        })
    }
}

/// Mean and SD of signed errors and the largest magnitude; `null` without data.
pub fn error_stats(e: &[f64]) -> Value {
    if e.is_empty() {
        return Value::Null;
    }
    let n = e.len() as f64;
    let mean = e.iter().sum::<f64>() / n;
    let sd = if e.len() > 1 {
        (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    let max = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    json!({"mean": mean, "sd": sd, "max": max, "n": e.len()})
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_statistics() {
        let v = error_stats(&[0.001, -0.001, 0.002, 0.0]);
        assert!((v["mean"].as_f64().expect("mean") - 0.0005).abs() < 1e-15);
        // Sample SD of [1, -1, 2, 0] mm is sqrt(5/3) mm.
        assert!((v["sd"].as_f64().expect("sd") - (5.0f64 / 3.0).sqrt() * 1e-3).abs() < 1e-12);
        assert_eq!(v["max"].as_f64(), Some(0.002));
        assert_eq!(error_stats(&[]), Value::Null);
    }
}
