//! How far the artery moves across its course between fixes in a way the path model cannot
//! explain: the tissue moving under the sensor (breathing, the heart's own motion).
//!
//! The path model describes a course that stays put. Tissue that moves 1-4 mm across it at a
//! breathing rate makes every fix a few millimetres off the last one's prediction; the
//! model, taking each fix at the localization's own SD (about a millimetre), bends its
//! course to follow each wiggle, extrapolates the wiggle as a turn and slides off the
//! artery. So each accepted fix's innovation is compared with the fix's own variance, and
//! the excess over the last few fixes is added to every fix's variance: the model then
//! averages the motion out and follows the mean course, while each located point stays
//! where it was felt.
//!
//! The reference is the fix's own variance, not the innovation's predicted variance: the
//! path model's fading memory widens its covariance at every surprising fix, so under
//! motion its predicted variance grows with the motion and the excess over it stays near
//! zero (measured on the breathing family: 2-7 mm² predicted against 1 mm² own).
//!
//! The median of the recent excesses, not their mean: a corner gives a few large
//! innovations and is the path's, which the path model's fading memory takes up; motion
//! gives large innovations on most fixes. Where the course is followed well the median
//! innovation is within the fix's own SD and nothing is added.

/// Fixes remembered.
const RECENT: usize = 9;
/// Fewest fixes before any motion is claimed.
const MIN_FIXES: usize = 5;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TissueMotion {
    excess_m2: [f64; RECENT],
    len: usize,
    next: usize,
    /// Largest SD claimed: beyond this the array (±9 mm) cannot follow the artery anyway,
    /// and the path gate (4 SD) would let in what lies beside it.
    max_sd_m: f64,
}

impl TissueMotion {
    pub fn new(max_sd_m: f64) -> Self {
        Self {
            excess_m2: [0.0; RECENT],
            len: 0,
            next: 0,
            max_sd_m: max_sd_m.max(0.0),
        }
    }

    /// Forget (a new trial).
    pub fn clear(&mut self) {
        self.len = 0;
        self.next = 0;
    }

    /// An accepted fix: its innovation and the fix's own variance (the localization's,
    /// without this motion's).
    pub fn push(&mut self, innovation_m: f64, expected_var_m2: f64) {
        let excess = innovation_m * innovation_m - expected_var_m2;
        if !excess.is_finite() {
            return;
        }
        self.excess_m2[self.next] = excess;
        self.next = (self.next + 1) % RECENT;
        self.len = (self.len + 1).min(RECENT);
    }

    /// SD of the unexplained motion across the course, m (0 while the course stays put).
    pub fn sd_m(&self) -> f64 {
        if self.len < MIN_FIXES {
            return 0.0;
        }
        let mut recent = [0.0; RECENT];
        recent[..self.len].copy_from_slice(&self.excess_m2[..self.len]);
        let recent = &mut recent[..self.len];
        recent.sort_by(f64::total_cmp);
        let median = if self.len % 2 == 1 {
            recent[self.len / 2]
        } else {
            0.5 * (recent[self.len / 2 - 1] + recent[self.len / 2])
        };
        median.max(0.0).sqrt().min(self.max_sd_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_still_course_claims_no_motion() {
        // Innovations drawn at the expected SD (a fixed sequence spanning ±2 SD).
        let mut m = TissueMotion::new(0.003);
        let sd = 0.0004;
        for k in 0..40 {
            let u = ((k * 7919) % 101) as f64 / 100.0; // 0..1, evenly spread
            m.push((2.0 * u - 1.0) * 1.6 * sd, sd * sd);
        }
        assert_eq!(m.sd_m(), 0.0);
    }

    #[test]
    fn breathing_is_measured_and_a_corner_is_not() {
        let sd = 0.0004;
        // A 3 mm sinusoid sampled once a second at 0.25 Hz + 0.1 (never in phase).
        let mut m = TissueMotion::new(0.01);
        for k in 0..20 {
            let t = k as f64 * 1.0;
            let d = 0.003 * (std::f64::consts::TAU * 0.27 * t).sin();
            let d_prev = 0.003 * (std::f64::consts::TAU * 0.27 * (t - 1.0)).sin();
            m.push(d - d_prev, sd * sd);
        }
        let got = m.sd_m();
        assert!(got > 0.002 && got < 0.006, "{got}");
        // Two large innovations among still ones (a corner) leave it at zero.
        let mut c = TissueMotion::new(0.01);
        for k in 0..9 {
            let innovation = if k == 4 || k == 5 { 0.004 } else { 0.3 * sd };
            c.push(innovation, sd * sd);
        }
        assert_eq!(c.sd_m(), 0.0);
    }

    #[test]
    fn too_few_fixes_or_bad_numbers_claim_nothing_and_the_cap_holds() {
        let mut m = TissueMotion::new(0.002);
        for _ in 0..4 {
            m.push(0.01, 0.0);
        }
        assert_eq!(m.sd_m(), 0.0);
        m.push(f64::NAN, 0.0);
        m.push(0.01, f64::INFINITY);
        assert_eq!(m.sd_m(), 0.0);
        m.push(0.01, 0.0);
        assert_eq!(m.sd_m(), 0.002);
        m.clear();
        assert_eq!(m.sd_m(), 0.0);
    }
}
