//! Is the tissue frame in use still true? Its touches were placed through the pivot and
//! read through the encoder zero in use then; a later pivot calibration or homing moves every
//! touched point (a pivot 5 mm off tilts the frame and shifts it by millimetres), so the frame
//! must be measured again before a trial or a search relies on it.

use config::calibration_file::{JointsRecord, PivotRecord, TissueRecord};

use serde_json::Value;

use super::Supervisor;

/// A pivot this far from the one the frame was measured through makes it stale, m.
const PIVOT_MOVED_M: f64 = 2e-4;
/// An encoder zero this far from the one it was read with, on any joint, rad (0.1 mm at
/// the sensor on the seed's 0.5 m rod).
const ZERO_MOVED_RAD: f64 = 2e-4;

/// What the tissue frame was measured against, and what is in use now.
pub struct InUse<'a> {
    /// The pivot the kinematics use, base frame, m (`None`: no kinematic model).
    pub pivot_in_base_m: Option<[f64; 3]>,
    pub joint_zero_rad: [f64; 3],
    pub pivot: Option<&'a PivotRecord>,
    pub joints: Option<&'a JointsRecord>,
}

/// Why `tissue` no longer places the tissue truly, for people; `None` while it does (or
/// when nothing says otherwise: a record from before 2026-11-28 that names neither, with no
/// calibration after it).
pub fn tissue_stale(tissue: &TissueRecord, now: &InUse<'_>) -> Option<String> {
    let again = "run `pulsetrack calibrate tissue` again before a trial or a search";
    let pivot_moved = match (tissue.pivot_in_base_m, now.pivot_in_base_m) {
        (Some(then), Some(in_use)) => {
            let d = distance(then, in_use);
            (d > PIVOT_MOVED_M).then(|| {
                format!(
                    "the tissue frame was measured through a pivot {:.2} mm from the one in use",
                    d * 1e3
                )
            })
        }
        (None, _) => now
            .pivot
            .filter(|p| p.measured_utc > tissue.measured_utc)
            .map(|p| {
                format!(
                    "the tissue frame was measured before the pivot calibration of {}",
                    p.measured_utc
                )
            }),
        (Some(_), None) => None,
    };
    let zero_moved = match tissue.joint_zero_rad {
        Some(then) => {
            let d = then
                .iter()
                .zip(now.joint_zero_rad)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            (d > ZERO_MOVED_RAD).then(|| {
                format!(
                    "the tissue frame was read through an encoder zero {:.3} deg from the one in use",
                    d.to_degrees()
                )
            })
        }
        None => now
            .joints
            .filter(|j| j.measured_utc > tissue.measured_utc)
            .map(|j| {
                format!(
                    "the tissue frame was measured before the homing of {}",
                    j.measured_utc
                )
            }),
    };
    let why: Vec<String> = [pivot_moved, zero_moved].into_iter().flatten().collect();
    (!why.is_empty()).then(|| format!("{}: {again}", why.join("; ")))
}

impl Supervisor {
    /// Why the tissue frame in use is no longer true, if it is not (`tissue_stale`).
    pub(super) fn tissue_stale(&self) -> Option<String> {
        let cal = &self.calibration;
        let tissue = cal.tissue_record()?;
        tissue_stale(
            tissue,
            &InUse {
                pivot_in_base_m: self.s.arm.map(|a| a.pivot().pivot_in_base_m),
                joint_zero_rad: cal.joint_zero(),
                pivot: cal.pivot_record(),
                joints: cal.joints.as_ref(),
            },
        )
    }
}

impl Supervisor {
    /// After a pivot calibration or a homing: say in its result event (`tissue_stale`) and
    /// its log line whether the tissue frame in use is still true.
    pub(super) fn note_tissue_stale(&self, ev: &mut Value, line: &mut String) {
        let stale = self.tissue_stale();
        if let Value::Object(o) = ev {
            o.insert("tissue_stale".into(), Value::from(stale.clone()));
        }
        if let Some(why) = stale {
            line.push_str("; ");
            line.push_str(&why);
        }
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
#[path = "tissue_stale_tests.rs"]
mod tests;
