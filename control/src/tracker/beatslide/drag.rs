//! Where the sensor trails the robot's belief: a two-dimensional play operator.
//!
//! The rod and the incision give way under the friction the tissue puts on the sensor
//! (about 10 mm/N on the seed's bench against about 0.35 N of sliding friction). While the
//! robot moves, the sensor slides a distance `L` behind it along the motion; when the robot
//! stops, static friction holds that deflection; when it sets off in a new direction, the
//! sensor stays put until the deflection has swung round to trail the new motion. That is a
//! play (backlash) operator of radius `L` on the believed position: the deflection `l` is
//! moved by every believed displacement and clipped to length `L`. This keeps its direction
//! `u = l / L` (length at most 1); `L` itself is estimated by the path filter. What the robot
//! needs for it is what it really has: its own believed motion.

use crate::frames::SurfacePoint;

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Drag {
    dir: [f64; 2],
    last: Option<SurfacePoint>,
}

/// Shortest lag the direction is kept for, m (below it every motion swings it round).
const MIN_LAG_M: f64 = 1e-4;

impl Drag {
    /// The lag's direction now (length 0 when unknown, 1 while sliding).
    pub fn dir(&self) -> [f64; 2] {
        self.dir
    }

    /// Forget which way the sensor trails (it rests near the belief), keeping where the
    /// belief was: the next motion sets the direction afresh.
    pub fn forget_direction(&mut self) {
        self.dir = [0.0, 0.0];
    }

    /// Move the belief to `believed` with the lag's length `lag_m`; returns the new
    /// direction. Non-finite positions are ignored.
    pub fn update(&mut self, believed: SurfacePoint, lag_m: f64) -> [f64; 2] {
        if !believed.is_finite() {
            return self.dir;
        }
        let lag = if lag_m.is_finite() {
            lag_m.max(MIN_LAG_M)
        } else {
            MIN_LAG_M
        };
        if let Some(last) = self.last {
            let l = [
                self.dir[0] * lag + believed.x_m - last.x_m,
                self.dir[1] * lag + believed.z_m - last.z_m,
            ];
            let n = l[0].hypot(l[1]);
            let scale = if n > lag { 1.0 / n } else { 1.0 / lag };
            self.dir = [l[0] * scale, l[1] * scale];
        }
        self.last = Some(believed);
        self.dir
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trails_the_motion_and_swings_round_on_reversal() {
        let lag = 0.004;
        let mut d = Drag::default();
        assert_eq!(d.update(SurfacePoint::new(0.0, 0.0), lag), [0.0, 0.0]);
        // 1 mm: the deflection builds up.
        let u = d.update(SurfacePoint::new(0.001, 0.0), lag);
        assert!((u[0] - 0.25).abs() < 1e-12 && u[1] == 0.0);
        for k in 2..20 {
            d.update(SurfacePoint::new(0.001 * k as f64, 0.0), lag);
        }
        assert!((d.dir()[0] - 1.0).abs() < 1e-12);
        // Stopping keeps it; a small wiggle does not flip it.
        d.update(SurfacePoint::new(0.019, 0.0), lag);
        d.update(SurfacePoint::new(0.0185, 0.0), lag);
        assert!(d.dir()[0] > 0.8);
        // Going back 2L swings it round fully.
        d.update(SurfacePoint::new(0.0185 - 0.009, 0.0), lag);
        assert!((d.dir()[0] + 1.0).abs() < 1e-12);
        // Turning at right angles: it ends along the new motion.
        for k in 1..20 {
            d.update(SurfacePoint::new(0.0095, 0.001 * k as f64), lag);
        }
        let u = d.dir();
        assert!(u[1] > 0.99 && u[0].abs() < 0.1, "{u:?}");
        assert!(u[0].hypot(u[1]) <= 1.0 + 1e-12);
        // Non-finite input changes nothing.
        assert_eq!(d.update(SurfacePoint::new(f64::NAN, 0.0), lag), u);
    }
}
