//! The artery's course ahead: a Kalman filter on lateral position, heading and curvature.
//!
//! The path is described in a local frame anchored at the last fix (origin on the path,
//! `s` along the estimated heading, `z'` to its left) as `z'(s) = a + b s + ½ c s²`: lateral
//! offset `a`, slope `b` (heading) and curvature `c`, with covariance `P`. The model is linear
//! in the state, so a fix `(s, z')` is an exact linear measurement `H = [1, s, s²/2]`. The
//! curvature is a random walk along the path (intensity `q`, `curvature_walk²`), so moving
//! the origin by `Δ` maps the state by `F = [[1, Δ, Δ²/2], [0, 1, Δ], [0, 0, 1]]` and adds the
//! integrated-random-walk noise `q [[Δ⁵/20, Δ⁴/8, Δ³/6], [Δ⁴/8, Δ³/3, Δ²/2], [Δ³/6, Δ²/2, Δ]]`.
//! After each update the frame is re-anchored on the estimate (`a = b = 0`), rotated by
//! `atan b`, so that `b` stays small and the parabola is a good local model however far the
//! path turns. On a straight path the curvature converges to zero and the prediction is a
//! straight line; after the first two points (the surgeon's placements) the curvature is
//! only its prior, and the predicted SD ahead grows as `s²/2` times that prior: the tracker
//! takes short steps until the curve is known.
//!
//! The sensor trails the robot's belief by a lag `L` along its motion (friction through the
//! compliant rod and incision, docs/tracker-beatslide.md): a fix reported in believed
//! coordinates is the artery point plus `L·u`, with `u` the lag's direction (unit while
//! sliding, from the caller's play operator). `L` is the fourth state, with a prior and a
//! slow random walk along the path. Moving along the artery (`u` along the path) leaves it
//! unobserved and harmless; any motion across the artery makes it observable and corrects
//! the fixes.
//!
//! The curvature's walk has two modes, an interacting multiple model (IMM): a calm one
//! (`curvature_walk`), which extrapolates far on a steady course, and a turning one
//! (`turning_walk`), which follows a curvature that reverses or a bend. Each keeps its own
//! estimate (`path_modes`) in the one frame; before each fix they are mixed by how likely
//! each is to have become the other, each takes the fix, and the fix's likelihood under
//! each weighs them. What the tracker reads (the path, its prediction, the gate) is their
//! merged estimate. Each mode must keep its own covariance across fixes: merged after every
//! fix (GPB1) the two differ by one step's process noise only, which a fix cannot tell
//! apart (docs/tracker-beatslide.md, "Two curvature walks"). With the two walks equal it
//! is one Kalman filter, exactly.
//!
//! A fix whose innovation exceeds the gate is refused (a lump, a neighbouring vessel). A fix
//! inside the gate but beyond two predicted SDs widens the path's covariance first (fading
//! memory): the model was too sure, as at an S-curve's inflection.

use nalgebra::{Matrix4, Vector4};

use super::path_modes::{self, Mode, Transition};
use crate::frames::SurfacePoint;

/// Normalized innovation squared beyond which the path's covariance is widened.
const NIS_INFLATE: f64 = 4.0;
/// Largest widening (of the SDs) from one fix.
const MAX_INFLATION: f64 = 3.0;

/// Settings of the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathFilterSettings {
    /// Prior SD of the lateral offset, slope and curvature before the first point.
    pub offset_prior_m: f64,
    pub slope_prior: f64,
    pub curvature_prior_per_m: f64,
    /// Curvature random walk of the calm mode, 1/m per √m.
    pub curvature_walk: f64,
    /// Curvature random walk of the turning mode, 1/m per √m; not above `curvature_walk`
    /// for one mode.
    pub turning_walk: f64,
    /// Probability that a calm path starts turning between two fixes, and that a turning
    /// one calms.
    pub turn_onset: f64,
    pub turn_end: f64,
    /// Prior of the sensor's lag behind the belief and its SD, m.
    pub lag_prior_m: f64,
    pub lag_prior_sd_m: f64,
    /// Random walk of the lag along the path, m per √m.
    pub lag_walk: f64,
    /// Gate: a fix is refused when its innovation exceeds both `gate_sigma` SDs and
    /// `gate_min_m`.
    pub gate_sigma: f64,
    pub gate_min_m: f64,
}

/// A point the path model refuses.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PathFilterError {
    #[error("the fix lies {innovation_m:.4} m off the predicted path (gate {gate_m:.4} m)")]
    OutsideGate { innovation_m: f64, gate_m: f64 },
    #[error("the fix or its uncertainty is not finite")]
    NonFinite,
    #[error("the points give no direction")]
    NoDirection,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathFilter {
    origin: SurfacePoint,
    heading_rad: f64,
    /// (a, b, c, L), the modes merged.
    x: Vector4<f64>,
    p: Matrix4<f64>,
    /// The calm and the turning mode's own estimates, in the same frame.
    modes: [Mode; 2],
    /// Their probabilities after the last fix.
    weights: [f64; 2],
    settings: PathFilterSettings,
    /// Fixes move only the path, not the lag ([`Self::hold_lag`]).
    lag_held: bool,
}

/// The turning mode's probability before any fix.
const TURNING_PRIOR: f64 = 0.5;

/// A fix: where it was reported (believed coordinates) and the lag's direction then.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    pub point: SurfacePoint,
    /// Lateral SD of the point from the localization alone, m.
    pub sd_m: f64,
    /// Direction of the sensor's lag behind the belief (tissue x, z), length at most 1;
    /// zero if unknown.
    pub lag_dir: [f64; 2],
}

/// How far a fix fell from the prediction, against how far the model expected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surprise {
    /// Lateral distance from the predicted path, m.
    pub innovation_m: f64,
    /// Its expected variance: the path's and the fix's own, m².
    pub var_m2: f64,
}

impl Surprise {
    /// Normalized innovation squared: about 1 when the model is right.
    pub fn nis(&self) -> f64 {
        self.innovation_m * self.innovation_m / self.var_m2
    }
}

/// What the filter predicts at some distance along the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    pub point: SurfacePoint,
    /// Lateral SD of the prediction, m.
    pub sd_m: f64,
    /// Heading of the path there, rad from `+x` toward `+z`.
    pub heading_rad: f64,
}

impl PathFilter {
    /// Start from observations of the path in order (at least two), the path heading
    /// about `heading_rad` (the direction the surgeon moved between the placements; the
    /// observations' own chord is used if that is not finite).
    pub fn from_observations(
        observations: &[Observation],
        heading_rad: f64,
        settings: PathFilterSettings,
    ) -> Result<Self, PathFilterError> {
        let n = observations.len();
        if n < 2
            || observations
                .iter()
                .any(|o| !(o.point.is_finite() && o.sd_m.is_finite() && o.sd_m > 0.0))
        {
            return Err(PathFilterError::NoDirection);
        }
        let (from, to) = (observations[0].point, observations[n - 1].point);
        let heading_rad = if heading_rad.is_finite() {
            heading_rad
        } else if from.distance_to(&to) >= 1e-6 {
            (to.z_m - from.z_m).atan2(to.x_m - from.x_m)
        } else {
            return Err(PathFilterError::NoDirection);
        };
        let prior = Mode {
            x: Vector4::new(0.0, 0.0, 0.0, settings.lag_prior_m),
            p: Matrix4::from_diagonal(&Vector4::new(
                settings.offset_prior_m.powi(2),
                settings.slope_prior.powi(2),
                settings.curvature_prior_per_m.powi(2),
                settings.lag_prior_sd_m.powi(2),
            )),
        };
        let mut f = Self {
            origin: to,
            heading_rad,
            x: prior.x,
            p: prior.p,
            modes: [prior; 2],
            weights: [1.0 - TURNING_PRIOR, TURNING_PRIOR],
            settings,
            lag_held: false,
        };
        for o in observations {
            let (s, z) = f.to_local(o.point);
            let h = Vector4::new(1.0, s, 0.5 * s * s, f.lateral(o.lag_dir));
            for m in &mut f.modes {
                m.measure_along(h, z, o.sd_m);
            }
        }
        f.merge();
        f.reanchor();
        Ok(f)
    }

    /// The lateral (left of the frame's heading) component of a tissue-frame vector.
    fn lateral(&self, v: [f64; 2]) -> f64 {
        let (sin, cos) = self.heading_rad.sin_cos();
        -v[0] * sin + v[1] * cos
    }

    /// The sensor's estimated lag behind the belief, m, and its SD.
    /// Hold the lag's estimate: fixes then move only the path (tissue moving under the
    /// sensor would otherwise be taken for lag).
    pub fn hold_lag(&mut self, held: bool) {
        self.lag_held = held;
    }

    pub fn lag_m(&self) -> f64 {
        self.x[3]
    }

    pub fn lag_sd_m(&self) -> f64 {
        self.p[(3, 3)].max(0.0).sqrt()
    }

    /// Where the artery point of an observation truly is, by the lag estimate.
    pub fn corrected(&self, o: &Observation) -> SurfacePoint {
        let l = self.x[3];
        SurfacePoint::new(
            o.point.x_m - l * o.lag_dir[0],
            o.point.z_m - l * o.lag_dir[1],
        )
    }

    /// `p` in the local frame: (along, left of) the origin.
    pub fn to_local(&self, p: SurfacePoint) -> (f64, f64) {
        let (sin, cos) = self.heading_rad.sin_cos();
        let (dx, dz) = (p.x_m - self.origin.x_m, p.z_m - self.origin.z_m);
        (dx * cos + dz * sin, -dx * sin + dz * cos)
    }

    fn point_at(&self, s: f64, z: f64) -> SurfacePoint {
        let (sin, cos) = self.heading_rad.sin_cos();
        SurfacePoint::new(
            self.origin.x_m + s * cos - z * sin,
            self.origin.z_m + s * sin + z * cos,
        )
    }

    /// The last fix's place on the path (the frame's origin).
    pub fn origin(&self) -> SurfacePoint {
        self.origin
    }

    pub fn heading_rad(&self) -> f64 {
        self.heading_rad
    }

    /// Estimated curvature, 1/m (positive turning left, toward `+z` from `+x`).
    pub fn curvature_per_m(&self) -> f64 {
        self.x[2]
    }

    pub fn curvature_sd_per_m(&self) -> f64 {
        self.p[(2, 2)].max(0.0).sqrt()
    }

    /// The path `s` metres along from the origin (negative: behind).
    pub fn predict(&self, s: f64) -> Prediction {
        let h = Vector4::new(1.0, s, 0.5 * s * s, 0.0);
        let z = h.dot(&self.x);
        let slope = self.x[1] + self.x[2] * s;
        let var = (h.transpose() * self.p * h)[0] + self.walk_variance(s.abs());
        Prediction {
            point: self.point_at(s, z),
            sd_m: var.max(0.0).sqrt(),
            heading_rad: self.heading_rad + slope.atan(),
        }
    }

    /// Lateral variance the curvature walk adds over `d` of path, the modes weighed by how
    /// likely each is at the next fix.
    fn walk_variance(&self, d: f64) -> f64 {
        let [q_calm, q_turning] = self.walks().map(|w| w * w);
        let q = if self.two_modes() {
            let [calm, turning] = self.mode_prior();
            calm * q_calm + turning * q_turning
        } else {
            q_calm
        };
        q * d.powi(5) / 20.0
    }

    /// The two modes' curvature walks (calm, turning).
    fn walks(&self) -> [f64; 2] {
        let calm = self.settings.curvature_walk;
        [calm, self.settings.turning_walk.max(calm)]
    }

    /// Whether the turning mode differs from the calm one (else this is one Kalman filter,
    /// exactly).
    fn two_modes(&self) -> bool {
        let [calm, turning] = self.walks();
        turning > calm
    }

    /// How the modes change between two fixes.
    fn transition(&self) -> Transition {
        let onset = self.settings.turn_onset.clamp(0.0, 1.0);
        let end = self.settings.turn_end.clamp(0.0, 1.0);
        [[1.0 - onset, onset], [end, 1.0 - end]]
    }

    /// The modes' probabilities at the next fix.
    fn mode_prior(&self) -> [f64; 2] {
        path_modes::predicted_weights(self.weights, &self.transition())
    }

    /// Probability that the path is turning (the turning mode's), after the last fix.
    pub fn turning_probability(&self) -> f64 {
        self.weights[1]
    }

    /// The merged estimate from the modes (the calm one's alone with one mode).
    fn merge(&mut self) {
        let m = if self.two_modes() {
            path_modes::merge(&self.modes, self.weights)
        } else {
            self.modes[0]
        };
        self.x = m.x;
        self.p = m.p;
    }

    /// Fold in a fix: the frame moves to the fix's place on the path. Refused (and the
    /// filter unchanged) outside the gate. Returns how surprising the fix was.
    pub fn update(&mut self, o: &Observation) -> Result<Surprise, PathFilterError> {
        let sd_m = o.sd_m;
        let p = o.point;
        if !(p.is_finite()
            && sd_m.is_finite()
            && sd_m > 0.0
            && o.lag_dir.iter().all(|v| v.is_finite()))
        {
            return Err(PathFilterError::NonFinite);
        }
        let (s, _) = self.to_local(self.corrected(o));
        let mut moved = *self;
        let prior = self.mode_prior();
        if self.two_modes() {
            moved.modes = path_modes::mixed(&self.modes, self.weights, &self.transition());
            moved.weights = prior;
        }
        moved.advance(s);
        let (s, z) = moved.to_local(p);
        let h = Vector4::new(1.0, s, 0.5 * s * s, moved.lateral(o.lag_dir));
        let innovation = z - h.dot(&moved.x);
        let var = (h.transpose() * moved.p * h)[0] + sd_m * sd_m;
        let gate = (self.settings.gate_sigma * var.sqrt()).max(self.settings.gate_min_m);
        if innovation.is_nan() || innovation.abs() > gate {
            return Err(PathFilterError::OutsideGate {
                innovation_m: innovation,
                gate_m: gate,
            });
        }
        if moved.two_modes() {
            let innovations = moved.modes.map(|m| z - h.dot(&m.x));
            let vars = moved
                .modes
                .map(|m| (h.transpose() * m.p * h)[0] + sd_m * sd_m);
            moved.weights = path_modes::posterior(prior, innovations, vars);
        }
        // Fading memory: an innovation well beyond what the model predicted means the path
        // has changed (an S-curve's inflection): widen the path's uncertainty so that the
        // fix counts for more, in proportion.
        let nis = innovation * innovation / var;
        if nis > NIS_INFLATE || self.lag_held {
            if nis > NIS_INFLATE {
                moved.inflate((nis / NIS_INFLATE).sqrt().min(MAX_INFLATION));
            }
            // The surprise is the path's, not the lag's: the lag is the rig's, and changes
            // slowly. Left free, it takes up part of every bend and is then subtracted from
            // every later fix (7 mm against a true 3 mm after one corner in the bends
            // family), so it is held here and this fix moves only the path.
            moved.measure_path_only(s, z, sd_m, h[3]);
        } else {
            moved.measure(h, z, sd_m);
        }
        moved.reanchor();
        *self = moved;
        Ok(Surprise {
            innovation_m: innovation,
            var_m2: var,
        })
    }

    /// Widen the path's uncertainty (after losing the pulse); the lag's is kept.
    pub fn inflate(&mut self, factor: f64) {
        if factor.is_finite() && factor >= 1.0 {
            let d = Matrix4::from_diagonal(&Vector4::new(factor, factor, factor, 1.0));
            for m in &mut self.modes {
                m.p = d * m.p * d;
            }
            self.merge();
        }
    }

    /// A fix that updates the path but not the lag: the lag's estimate stays, its
    /// correlation with the path is dropped, and its current value is taken off the fix.
    fn measure_path_only(&mut self, s: f64, z: f64, sd_m: f64, h_lag: f64) {
        let h = Vector4::new(1.0, s, 0.5 * s * s, 0.0);
        for m in &mut self.modes {
            m.decouple_lag();
            let lag = m.x[3];
            m.measure_along(h, z - lag * h_lag, sd_m);
        }
        self.merge();
    }

    /// A direct reading of the lag, with its SD (the arm's load: where it puts the sensor
    /// less where it is believed, along the lag's direction). It reads the rig, not the
    /// artery: it moves the lag alone, its correlation with the path (learned from fixes,
    /// which confound the two) dropped first; through that correlation it moved points at
    /// an S-curve's inflection by up to 0.6 mm. Taken whether or not the lag is held
    /// against fixes.
    pub fn measure_lag(&mut self, lag_m: f64, sd_m: f64) {
        if !(lag_m.is_finite() && sd_m.is_finite() && sd_m > 0.0) {
            return;
        }
        for m in &mut self.modes {
            m.decouple_lag();
            m.measure_along(Vector4::new(0.0, 0.0, 0.0, 1.0), lag_m, sd_m);
        }
        self.merge();
    }

    /// Every mode takes the reading `z = h·x` with SD `sd_m`.
    fn measure(&mut self, h: Vector4<f64>, z: f64, sd_m: f64) {
        for m in &mut self.modes {
            m.measure_along(h, z, sd_m);
        }
        self.merge();
    }

    /// Move the origin `d` along the path (each mode with its curvature walk's noise), then
    /// re-anchor.
    fn advance(&mut self, d: f64) {
        if !d.is_finite() || d == 0.0 {
            return;
        }
        let f = Matrix4::new(
            1.0,
            d,
            0.5 * d * d,
            0.0,
            0.0,
            1.0,
            d,
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
            0.0,
            0.0,
            0.0,
            1.0,
        );
        let a = d.abs();
        let block = [
            [a.powi(5) / 20.0, a.powi(4) / 8.0, a.powi(3) / 6.0],
            [a.powi(4) / 8.0, a.powi(3) / 3.0, a * a / 2.0],
            [a.powi(3) / 6.0, a * a / 2.0, a],
        ];
        let lag_noise = self.settings.lag_walk.powi(2) * a;
        // The new origin is on the frame's axis at `d`; the states now describe the path
        // about it.
        self.origin = self.point_at(d, 0.0);
        let walks = self.walks();
        for (m, walk) in self.modes.iter_mut().zip(walks) {
            let q = walk * walk;
            let mut qm = Matrix4::zeros();
            for (i, row) in block.iter().enumerate() {
                for (j, v) in row.iter().enumerate() {
                    qm[(i, j)] = q * v;
                }
            }
            qm[(3, 3)] = lag_noise;
            m.x = f * m.x;
            m.p = f * m.p * f.transpose() + qm;
        }
        self.merge();
        self.reanchor();
    }

    /// Put the frame on the estimate: the origin moves to the path point `a` to the side,
    /// the heading turns by `atan b`; the state becomes (0, 0, curvature).
    fn reanchor(&mut self) {
        let (a, b) = (self.x[0], self.x[1]);
        self.origin = self.point_at(0.0, a);
        let beta = b.atan();
        let cos = beta.cos();
        self.heading_rad += beta;
        // Each mode moves with the frame, linearized about the merged estimate (the modes
        // lie within millimetres and hundredths of a radian of it), so that the merged
        // estimate becomes (0, 0, κ, L) as with one mode.
        let j = Matrix4::from_diagonal(&Vector4::new(cos, cos * cos, cos.powi(3), 1.0));
        let shift = Vector4::new(a, b, 0.0, 0.0);
        for m in &mut self.modes {
            m.x = j * (m.x - shift);
            m.p = j * m.p * j.transpose();
            m.p = 0.5 * (m.p + m.p.transpose());
        }
        self.merge();
    }
}

#[cfg(test)]
#[path = "path_filter_modes_tests.rs"]
mod modes_tests;

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> PathFilterSettings {
        PathFilterSettings {
            offset_prior_m: 0.002,
            slope_prior: 0.5,
            curvature_prior_per_m: 1.0 / 0.06,
            curvature_walk: 30.0,
            turning_walk: 30.0,
            turn_onset: 0.1,
            turn_end: 0.1,
            lag_prior_m: 0.0,
            lag_prior_sd_m: 1e-6,
            lag_walk: 1e-6,
            gate_sigma: 4.0,
            gate_min_m: 0.002,
        }
    }

    fn obs(point: SurfacePoint, sd_m: f64) -> Observation {
        Observation {
            point,
            sd_m,
            lag_dir: [0.0, 0.0],
        }
    }

    fn start(points: &[SurfacePoint], sd_m: f64) -> Result<PathFilter, PathFilterError> {
        let o: Vec<Observation> = points.iter().map(|p| obs(*p, sd_m)).collect();
        PathFilter::from_observations(&o, f64::NAN, settings())
    }

    fn on_circle(r: f64, s: f64) -> SurfacePoint {
        // Starting at the origin heading +x, turning left.
        let th = s / r;
        SurfacePoint::new(r * th.sin(), r * (1.0 - th.cos()))
    }

    #[test]
    fn a_straight_path_predicts_a_straight_line() {
        let heading = 0.7f64;
        let at = |s: f64| SurfacePoint::new(0.01 + s * heading.cos(), -0.02 + s * heading.sin());
        let mut f = start(&[at(0.0), at(0.01)], 0.0003).expect("two points");
        for k in 2..20 {
            f.update(&obs(at(0.01 * k as f64), 0.0003))
                .expect("on the path");
        }
        assert!(f.curvature_per_m().abs() < 0.5, "{}", f.curvature_per_m());
        assert!((f.heading_rad() - heading).abs() < 0.01);
        let ahead = f.predict(0.02);
        let want = at(0.21);
        assert!(ahead.point.distance_to(&want) < 0.3e-3, "{ahead:?}");
        assert!(ahead.sd_m < 2.5e-3, "{ahead:?}");
        // Further ahead the curvature walk makes it less sure, as s^(5/2).
        assert!(f.predict(0.05).sd_m > 2.0 * ahead.sd_m);
    }

    #[test]
    fn learns_a_circle_and_predicts_round_it() {
        for &r in &[0.06, 0.08, 0.145] {
            let mut f =
                start(&[on_circle(r, 0.0), on_circle(r, 0.01)], 0.0003).expect("two points");
            // Early on the uncertainty ahead is large: it takes short steps.
            let sd_early = f.predict(0.02).sd_m;
            for k in 2..12 {
                f.update(&obs(on_circle(r, 0.01 * k as f64), 0.0003))
                    .expect("on the circle");
            }
            assert!(
                (f.curvature_per_m() - 1.0 / r).abs() < 0.15 / r,
                "r {r}: {}",
                f.curvature_per_m()
            );
            let p = f.predict(0.02);
            assert!(
                p.point.distance_to(&on_circle(r, 0.13)) < 0.6e-3,
                "r {r}: {p:?}"
            );
            assert!(p.sd_m < sd_early, "{} vs {sd_early}", p.sd_m);
            // A point well off the predicted path is refused and leaves the filter alone.
            let before = f;
            let ahead = f.predict(0.015);
            let (sin, cos) = ahead.heading_rad.sin_cos();
            let off =
                SurfacePoint::new(ahead.point.x_m - 0.012 * sin, ahead.point.z_m + 0.012 * cos);
            assert!(matches!(
                f.update(&obs(off, 0.0003)),
                Err(PathFilterError::OutsideGate { .. })
            ));
            assert_eq!(f, before);
        }
    }

    #[test]
    fn follows_an_s_curve_through_its_inflection() {
        // Two 120 mm arcs of opposite turn.
        let r = 0.12;
        let half = 0.13;
        let at = |s: f64| {
            if s <= half {
                on_circle(r, s)
            } else {
                let p = on_circle(r, half);
                let th = half / r;
                // Continue turning right from heading th.
                let u = s - half;
                let phi = th - u / r;
                SurfacePoint::new(
                    p.x_m + r * (th.sin() - phi.sin()),
                    p.z_m - r * (th.cos() - phi.cos()),
                )
            }
        };
        let mut f = start(&[at(0.0), at(0.01)], 0.0003).expect("ok");
        let mut errors = Vec::new();
        for k in 2..26 {
            let s = 0.01 * k as f64;
            let p = f.predict(0.01);
            errors.push(p.point.distance_to(&at(s)));
            f.update(&obs(at(s), 0.0003))
                .expect("inside the gate through the inflection");
        }
        let worst = errors.iter().cloned().fold(0.0, f64::max);
        assert!(worst < 2.5e-3, "worst one-step prediction error {worst}");
        // Settled again on the second arc.
        let late = errors[errors.len() - 5..]
            .iter()
            .cloned()
            .fold(0.0, f64::max);
        assert!(late < 0.5e-3, "{errors:?}");
        assert!(f.curvature_per_m() < -0.5 / r, "{}", f.curvature_per_m());
    }

    /// Settings believing a 2 mm lag, ±2 mm, free to change.
    fn lag_settings() -> PathFilterSettings {
        PathFilterSettings {
            lag_prior_m: 0.002,
            lag_prior_sd_m: 0.002,
            lag_walk: 0.001,
            ..settings()
        }
    }

    /// Fix `k` on a straight artery along x, the sensor trailing the belief by 4 mm along a
    /// motion swinging ±20° about the artery.
    fn swinging(k: usize) -> Observation {
        let psi = if k.is_multiple_of(2) { 0.35f64 } else { -0.35 };
        let u = [psi.cos(), psi.sin()];
        Observation {
            point: SurfacePoint::new(0.01 * k as f64 + 0.004 * u[0], 0.004 * u[1]),
            sd_m: 0.0002,
            lag_dir: u,
        }
    }

    #[test]
    fn learns_the_sensor_lag_from_motion_across_the_path() {
        // A straight artery along x; the sensor trails the belief by 4 mm along a motion
        // that swings ±20° about the artery, so each reported point is off by the lag's
        // lateral part. The filter starts believing 2 mm.
        let lag = 0.004;
        let (s, observe) = (lag_settings(), swinging);
        let mut f =
            PathFilter::from_observations(&[observe(0), observe(1)], 0.0, s).expect("two points");
        for k in 2..30 {
            f.update(&observe(k)).expect("on the path");
        }
        assert!((f.lag_m() - lag).abs() < 0.4e-3, "lag {}", f.lag_m());
        let c = f.corrected(&observe(30));
        assert!(
            c.z_m.abs() < 0.2e-3 && (c.x_m - 0.3).abs() < 0.5e-3,
            "{c:?}"
        );
        assert!(f.curvature_per_m().abs() < 1.0);
        // Without the lag model the same points would zig-zag by ±1.4 mm.
        assert!(observe(30).point.z_m.abs() > 1.3e-3);
    }

    #[test]
    fn a_held_lag_is_not_moved_by_the_fixes() {
        // The fixes of the test above, which teach a 4 mm lag to a filter believing 2 mm:
        // with the lag held (tissue moving under the sensor), it stays at 2 mm while the
        // path still follows the fixes.
        let (s, observe) = (lag_settings(), swinging);
        let mut f =
            PathFilter::from_observations(&[observe(0), observe(1)], 0.0, s).expect("two points");
        let start = f.lag_m();
        f.hold_lag(true);
        for k in 2..30 {
            f.update(&observe(k)).expect("on the path");
        }
        assert_eq!(f.lag_m(), start);
        assert!((f.origin().x_m - 0.29).abs() < 0.01, "{:?}", f.origin());
        f.hold_lag(false);
        for k in 30..60 {
            f.update(&observe(k)).expect("on the path");
        }
        assert!((f.lag_m() - 0.004).abs() < 0.4e-3, "lag {}", f.lag_m());
    }

    #[test]
    fn a_read_lag_moves_the_lag_by_its_weight_and_not_the_path() {
        // The swinging fixes correlate the lag with the path; a reading of 9 mm (±0.5)
        // then moves the lag by the Kalman weight of its variance against the lag's own,
        // and leaves the path where the fixes put it.
        let (s, observe) = (lag_settings(), swinging);
        let mut f =
            PathFilter::from_observations(&[observe(0), observe(1)], 0.0, s).expect("two points");
        for k in 2..6 {
            f.update(&observe(k)).expect("on the path");
        }
        assert!(f.p[(0, 3)].abs() > 0.0, "the fixes correlate lag and path");
        let (lag, var) = (f.lag_m(), f.lag_sd_m().powi(2));
        let ahead = f.predict(0.02);
        let (origin, heading, curvature) = (f.origin(), f.heading_rad(), f.curvature_per_m());
        let (reading, sd) = (0.009, 0.0005);
        f.measure_lag(reading, sd);
        let expected = lag + var / (var + sd * sd) * (reading - lag);
        assert!(
            (f.lag_m() - expected).abs() < 1e-12,
            "{} vs {expected}",
            f.lag_m()
        );
        assert!(f.lag_sd_m() < sd, "{}", f.lag_sd_m());
        assert_eq!((f.origin(), f.heading_rad()), (origin, heading));
        assert_eq!(f.curvature_per_m(), curvature);
        let now = f.predict(0.02);
        assert_eq!((now.point, now.sd_m), (ahead.point, ahead.sd_m));
        // Held against fixes or not, a reading is taken; a non-finite one, or one with no
        // spread, is not.
        f.hold_lag(true);
        let before = f.lag_m();
        f.measure_lag(0.010, sd);
        assert!(f.lag_m() > before);
        let held = f;
        for (bad, sd) in [
            (f64::NAN, sd),
            (0.01, 0.0),
            (0.01, f64::INFINITY),
            (f64::INFINITY, sd),
        ] {
            let mut g = held;
            g.measure_lag(bad, sd);
            assert_eq!(
                (g.lag_m(), g.lag_sd_m()),
                (held.lag_m(), held.lag_sd_m()),
                "{bad} {sd}"
            );
        }
    }

    #[test]
    fn degenerate_inputs() {
        let p = SurfacePoint::new(0.0, 0.0);
        assert_eq!(start(&[p], 0.001), Err(PathFilterError::NoDirection));
        assert_eq!(start(&[p, p], 0.001), Err(PathFilterError::NoDirection));
        assert_eq!(
            start(&[p, SurfacePoint::new(f64::NAN, 0.0)], 0.001),
            Err(PathFilterError::NoDirection)
        );
        let mut f = start(&[p, SurfacePoint::new(0.01, 0.0)], 0.001).expect("ok");
        assert_eq!(
            f.update(&obs(SurfacePoint::new(f64::INFINITY, 0.0), 0.001)),
            Err(PathFilterError::NonFinite)
        );
        assert_eq!(
            f.update(&obs(SurfacePoint::new(0.02, 0.0), 0.0)),
            Err(PathFilterError::NonFinite)
        );
        // A fix behind the origin (after going back) is accepted.
        f.update(&obs(SurfacePoint::new(0.005, 0.0002), 0.0003))
            .expect("behind is fine");
        assert!(f.predict(0.01).point.x_m.is_finite());
    }
}
