//! What one simulated trial produced: the located points with where the sensor truly was,
//! how the trial ended, and the lateral error statistics. Serialized as documented in
//! docs/sim-json.md (the schema is an interface: extend it, never rename).

use control::frames::SurfacePoint;
use control::types::TactileFrame;
use serde::Serialize;

use crate::scene::{ArteryPath, Breathing};

/// A located point farther than this from the true artery is a false point: the tracker
/// reported a place it did not feel, m.
pub const FALSE_POINT_M: f64 = 0.002;

/// One artery point the tracker reported.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocatedSample {
    /// Simulated time of the localization, s.
    pub t_s: f64,
    /// The reported artery point, tissue frame, m.
    pub x_m: f64,
    pub z_m: f64,
    /// Where the sensor centre truly was when it localized (the robot believed it was
    /// elsewhere: encoders through the fixed-pivot model), m.
    pub true_x_m: f64,
    pub true_z_m: f64,
    /// True for the surgeon's two manual placements.
    pub seed: bool,
    /// Signed lateral offset of the reported point from the true path (+ on the path's left
    /// normal, the `+z` side when travelling along `+x`), m.
    pub lateral_error_m: f64,
    /// Arc length along the true path of the point's nearest path point, m.
    pub along_path_m: f64,
    /// The tracker's own uncertainty of the point across the artery, one SD, m (absent:
    /// the tracker gives none). `lateral_error_m / sd_m` says whether it is honest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sd_m: Option<f64>,
}

/// Mean and SD of the signed lateral offsets, and the 95th percentile and the largest of
/// the absolute ones.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LateralError {
    pub mean: f64,
    pub sd: f64,
    pub max: f64,
    /// The 95th percentile of the absolute offsets (nearest rank), m.
    pub p95: f64,
    /// Points the statistics cover (the autonomous ones, not the manual placements).
    pub points: usize,
}

impl LateralError {
    /// Statistics of signed errors (SD with n − 1; zero for fewer than two points).
    pub fn of(errors: &[f64]) -> Self {
        let n = errors.len();
        if n == 0 {
            return Self {
                mean: 0.0,
                sd: 0.0,
                max: 0.0,
                p95: 0.0,
                points: 0,
            };
        }
        let mean = errors.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 {
            (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let max = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        Self {
            mean,
            sd,
            max,
            p95: abs_percentile(errors, 0.95),
            points: n,
        }
    }
}

/// The `q` quantile (nearest rank) of the absolute values of `values`; 0 when empty.
pub fn abs_percentile(values: &[f64], q: f64) -> f64 {
    let mut abs: Vec<f64> = values.iter().map(|e| e.abs()).collect();
    if abs.is_empty() {
        return 0.0;
    }
    abs.sort_by(f64::total_cmp);
    let rank = (q * abs.len() as f64).ceil() as usize;
    abs[rank.clamp(1, abs.len()) - 1]
}

/// An arm that stopped short of where it was sent (judged from the encoders through the
/// kinematics): nothing was marked or fixed there.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShortfallReport {
    /// `placement 1`, `placement 2` or `tracking target`.
    pub what: String,
    /// Where the arm was sent, tissue frame, m.
    pub target_x_m: f64,
    pub target_z_m: f64,
    /// Believed sensor centre to the target when the settling time ran out, m.
    pub shortfall_m: f64,
    /// `stalled` (at rest short of it) or `not_at_rest`.
    pub reason: String,
}

/// One trial's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialResult {
    /// The random seed the trial ran with (rerun it with `--seed`).
    pub seed: u64,
    /// Every located point in order, manual placements first.
    pub located: Vec<LocatedSample>,
    /// Simulated seconds from the start of autonomous tracking to its end.
    pub duration_s: f64,
    /// Heartbeats (pulse cycles) begun in that time.
    pub beats: u64,
    /// Times the tracker went back toward the last place it found the pulse.
    pub backtracks: u32,
    /// Acquisitions that found no pulse.
    pub misses: u32,
    /// True if the trial followed the requested length.
    pub completed: bool,
    /// Why tracking ended: `length_reached`, `lost`, `workspace_edge`, `stopped`, or the
    /// runner's own `not_seeded` (a manual placement found no pulse), `short_of_target` (the
    /// arm stopped short of a placement or a tracking target: see `shortfall`), `timeout`
    /// (simulated time limit) and `fault` (the controller tripped).
    pub end_reason: String,
    /// A sentence on what went wrong, when something did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detail: Option<String>,
    /// With `short_of_target`: where the arm did not get, by how much and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shortfall: Option<ShortfallReport>,
    /// Lateral error of the autonomous points from the true path, m.
    pub lateral_error_m: LateralError,
    /// Located points (the manual placements' seed points included) more than
    /// [`FALSE_POINT_M`] from the true path.
    pub false_points: usize,
    /// Path length followed along the located points from the first placement, m.
    pub tracked_length_m: f64,
    /// Simulated seconds of the whole trial, placements included.
    pub simulated_s: f64,
    /// Wall-clock seconds the trial took to simulate.
    pub wall_s: f64,
    /// Raw frames of the first acquisition at the first placement (for the Fig. 2 plot).
    #[serde(skip)]
    pub first_acquisition: Vec<TactileFrame>,
    /// The sensor every 100 ms: (t, believed, true), for plots.
    #[serde(skip)]
    pub sensor_track: Vec<(f64, SurfacePoint, SurfacePoint)>,
    /// Every tracker event with the believed and true sensor positions, for diagnosis.
    #[serde(skip)]
    pub log: Vec<crate::trial_event::TrialEvent>,
}

impl TrialResult {
    /// Score located points against the true path.
    pub fn score(path: &ArteryPath, points: &mut [LocatedSample]) -> LateralError {
        Self::score_moving(path, None, points)
    }

    /// Score located points against the true path where it lay at each point's time (the
    /// tissue moves with `breathing`).
    pub fn score_moving(
        path: &ArteryPath,
        breathing: Option<&Breathing>,
        points: &mut [LocatedSample],
    ) -> LateralError {
        let mut errors = Vec::with_capacity(points.len());
        for p in points.iter_mut() {
            let at = SurfacePoint::new(p.x_m, p.z_m);
            let at = breathing.map_or(at, |b| b.to_rest(at, p.t_s));
            let n = path.nearest(at);
            p.lateral_error_m = n.offset_m;
            p.along_path_m = n.s_m;
            if !p.seed {
                errors.push(n.offset_m);
            }
        }
        LateralError::of(&errors)
    }
}

/// Located points in `points` farther than [`FALSE_POINT_M`] from the true path (scored).
pub fn false_points(points: &[LocatedSample]) -> usize {
    points
        .iter()
        .filter(|p| p.lateral_error_m.abs() > FALSE_POINT_M)
        .count()
}

/// Summary over several trials.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrialsSummary {
    pub trials: usize,
    pub completed: usize,
    /// SD of the lateral error over all autonomous points of all trials, m.
    pub pooled_sd_m: f64,
    pub pooled_mean_m: f64,
    pub backtracks_per_trial: f64,
    pub mean_duration_s: f64,
}

impl TrialsSummary {
    pub fn of(trials: &[TrialResult]) -> Self {
        let errors: Vec<f64> = trials
            .iter()
            .flat_map(|t| {
                t.located
                    .iter()
                    .filter(|p| !p.seed)
                    .map(|p| p.lateral_error_m)
            })
            .collect();
        let pooled = LateralError::of(&errors);
        let n = trials.len().max(1) as f64;
        Self {
            trials: trials.len(),
            completed: trials.iter().filter(|t| t.completed).count(),
            pooled_sd_m: pooled.sd,
            pooled_mean_m: pooled.mean,
            backtracks_per_trial: trials.iter().map(|t| t.backtracks as f64).sum::<f64>() / n,
            mean_duration_s: trials.iter().map(|t| t.duration_s).sum::<f64>() / n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_signed_errors() {
        let e = LateralError::of(&[0.001, -0.003, 0.002]);
        assert!(e.mean.abs() < 1e-15);
        assert!((e.sd - (14e-6f64 / 2.0).sqrt()).abs() < 1e-12);
        assert_eq!(e.max, 0.003);
        assert_eq!(e.p95, 0.003);
        let many: Vec<f64> = (1..=100).map(|i| -(i as f64)).collect();
        assert_eq!(LateralError::of(&many).p95, 95.0);
        assert_eq!(abs_percentile(&[], 0.95), 0.0);
        assert_eq!(LateralError::of(&[]).points, 0);
        assert_eq!(LateralError::of(&[0.5]).sd, 0.0);
    }
}
