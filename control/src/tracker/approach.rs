//! The robot's believed sensor positions before a trial's first mark (the surgeon's approach
//! to the first placement), kept as a bounded polyline, so that the lockstep runner and the
//! daemon hand a tracker the same record of it (`Tracker::approach`).
//!
//! Positions closer than `STEP_M` to the last one kept are skipped: the motion that matters
//! (how a compliant rod trails the robot) depends on the path, not on the rate it was
//! sampled at, and encoder noise at rest must not fill the trail.

use std::collections::VecDeque;

use super::Tracker;
use crate::frames::SurfacePoint;

/// Smallest step kept, m.
pub const STEP_M: f64 = 2e-4;
/// Most points kept (at least `MAX_POINTS × STEP_M` = 51 mm of the latest path).
pub const MAX_POINTS: usize = 256;

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ApproachTrail {
    points: VecDeque<SurfacePoint>,
}

impl ApproachTrail {
    /// Add the believed position now; non-finite positions are ignored.
    pub fn push(&mut self, p: SurfacePoint) {
        if !p.is_finite() {
            return;
        }
        if self
            .points
            .back()
            .is_some_and(|b| b.distance_to(&p) < STEP_M)
        {
            return;
        }
        if self.points.len() == MAX_POINTS {
            self.points.pop_front();
        }
        self.points.push_back(p);
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Hand the trail to `tracker`, oldest first, and empty it; returns what was handed.
    pub fn hand_to(&mut self, tracker: &mut dyn Tracker) -> Vec<SurfacePoint> {
        let points: Vec<SurfacePoint> = self.points.drain(..).collect();
        for p in &points {
            tracker.approach(*p);
        }
        points
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_path_not_the_samples_and_stays_bounded() {
        let mut t = ApproachTrail::default();
        // At rest with encoder noise well under a step: one point.
        for k in 0..1000 {
            t.push(SurfacePoint::new(1e-6 * (k % 3) as f64, 0.0));
        }
        assert_eq!(t.len(), 1);
        t.push(SurfacePoint::new(f64::NAN, 0.0));
        assert_eq!(t.len(), 1);
        // A 100 mm slide sampled every 0.01 mm: one point per step, the newest kept.
        for k in 1..=10_000 {
            t.push(SurfacePoint::new(1e-5 * k as f64, 0.0));
        }
        assert_eq!(t.len(), MAX_POINTS);
        let last = *t.points.back().expect("points");
        assert!((last.x_m - 0.1).abs() <= STEP_M, "{last:?}");
        let first = *t.points.front().expect("points");
        assert!(last.x_m - first.x_m >= (MAX_POINTS - 1) as f64 * STEP_M);
    }
}
