//! `beatslide` at a mark whose artery lies beyond the array's end: move over it and mark
//! again.
//!
//! A placement can leave the artery beyond the array's reach: a heavy instrument's rod sags
//! so that the sensor rests 6-10 mm from where the kinematics put it, and a surgeon's
//! placement is not exact. The kernel fit then has only a flank to go by; its centre is
//! extrapolated beyond the outer element, with an SD of several millimetres, and on the
//! fresh heavy-instrument draws two such seed points lay 2.2-3.1 mm off. A mark must answer
//! (the runner and the daemon wait for it), but it need not answer from there: the fit says
//! which way the artery is, so the sensor moves along the array until the artery lies
//! `REPLACE_SHORT_M` from its centre (at most `MAX_REPLACE_M`) and the mark starts again
//! over it. Found on the array's far half instead, the artery was not where the flank said
//! (on the 30 mm arc it runs along the array there, and two of seven such marks put it 5-6
//! mm off with an SD of 1 mm): the placement's own mark stands, with its SD, as it does when
//! the mark after the move finds nothing. Once per mark. The placement, not the sensor's new
//! place, stays what says which way the surgeon went along the artery (`BeatSlide::start`).

use super::*;

/// A mark's outcome at its placement, kept while the sensor moves onto the artery and
/// marks again; `side` is the side of the array's centre (+1 or -1 along z) the move was to
/// bring the artery to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Replaced {
    pub outcome: MarkOutcome,
    pub side: f64,
}

/// Longest move onto an artery felt beyond the array's end, m: a little more than the
/// array's half span, so that an artery just beyond the end comes onto the array, and a
/// far extrapolation does not carry the sensor away from the surgeon's placement.
const MAX_REPLACE_M: f64 = 0.012;

/// The move stops this short of putting the artery under the array's centre, m: on the
/// tuning seeds (heavy-instrument 1001-1060) aiming at the centre completed 58 trials
/// against 56, but put 5 points more than 2 mm off against 1 (a longer move carries the
/// sensor further along an artery that runs at a slant to the array).
const REPLACE_SHORT_M: f64 = 0.003;

/// A move onto the artery that does not arrive within this long is given up, and the mark
/// made where the sensor is, s.
const REPLACE_TIMEOUT_S: f64 = 20.0;

impl BeatSlide {
    /// Does this mark's fit place the artery beyond the outer elements' centres (or at the
    /// end of the searched range), and may the mark move onto it?
    pub(super) fn should_replace(&self, fit: &KernelFit) -> bool {
        let outer = (crate::types::ELEMENTS - 1) as f64;
        self.seat_home.is_none()
            && fit.offset_z_m.is_finite()
            && (fit.at_edge || fit.element < 0.0 || fit.element > outer)
    }

    /// Keep the mark's outcome at the placement and begin the move from the window's mean
    /// sensor place `sensor` onto the artery the fit `fit` puts beside it.
    pub(super) fn begin_replacing(
        &mut self,
        outcome: MarkOutcome,
        fit: &KernelFit,
        sensor: SurfacePoint,
        t_s: f64,
    ) {
        self.replaced = Some(Replaced {
            outcome,
            side: fit.offset_z_m.signum(),
        });
        let dz = (fit.offset_z_m - REPLACE_SHORT_M * fit.offset_z_m.signum())
            .clamp(-MAX_REPLACE_M, MAX_REPLACE_M);
        self.state = State::Replacing {
            target: SurfacePoint::new(sensor.x_m, sensor.z_m + dz),
            since_s: t_s,
            frames: 0,
        };
    }

    /// While moving onto the artery: once arrived (or given up), mark afresh.
    pub(super) fn step_replacing(
        &mut self,
        input: &TrackerInput<'_>,
        target: SurfacePoint,
        since_s: f64,
        frames: u64,
    ) {
        if (frames > 0 && input.settled) || input.frame.t_s - since_s > REPLACE_TIMEOUT_S {
            self.begin_marking();
            return;
        }
        self.state = State::Replacing {
            target,
            since_s,
            frames: frames.saturating_add(1),
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::kernel_fit::element_kernel;
    use crate::types::{ELEMENTS, TactileFrame};

    /// Mark at a placement at the tissue frame's origin, the sensor following each move at
    /// once; `centre(z)` is the (fractional) element the artery lies under with the sensor
    /// at `z` along the array (`None`: no pulse there). Returns the mark's point, the moves
    /// made, and the tracker.
    fn mark_with(
        params: BeatSlideParams,
        centre: impl Fn(f64) -> Option<f64>,
    ) -> (Option<LocatedPoint>, Vec<SurfacePoint>, BeatSlide) {
        let geometry = ArrayGeometry::default();
        let mut t = BeatSlide::new(params, geometry).expect("params");
        t.mark().expect("seeding");
        let (pitch, fs) = (geometry.pitch_m, geometry.sample_rate_hz);
        let mut noise = test_noise(99, 0.004);
        let mut sensor = SurfacePoint::new(0.0, 0.0);
        let mut moves = Vec::new();
        let mut settled = true;
        for seq in 0..(120.0 * fs) as u64 {
            let t_s = seq as f64 / fs;
            let pulse = 0.05 * (std::f64::consts::TAU * t_s).cos();
            let c = centre(sensor.z_m);
            let force_n: [f64; ELEMENTS] = std::array::from_fn(|e| {
                let felt = c.map_or(0.0, |c| {
                    pulse * element_kernel((e as f64 - c) * pitch, 0.005, pitch)
                });
                0.4 + felt + noise()
            });
            let frame = TactileFrame { t_s, seq, force_n };
            let out = t.step(&TrackerInput {
                frame: &frame,
                sensor,
                settled,
                loaded_sensor: None,
            });
            settled = true;
            if let MotionCommand::MoveTo { target, .. } = out.motion
                && target.distance_to(&sensor) > 1e-9
            {
                sensor = target;
                moves.push(target);
                settled = false;
            }
            match out.event {
                Some(TrackerEvent::Located(p)) => return (Some(p), moves, t),
                Some(TrackerEvent::Missed { .. }) => return (None, moves, t),
                _ => {}
            }
        }
        (None, moves, t)
    }

    /// An artery 11 mm beside the placement along +z, beyond the array's end (its outer
    /// element's centre is 9 mm out).
    const BESIDE_M: f64 = 0.011;

    fn beside(z_m: f64) -> f64 {
        4.5 + (BESIDE_M - z_m) / 0.002
    }

    /// The test's arm puts the sensor where it is told, with no lag behind its moves.
    fn lagless() -> BeatSlideParams {
        BeatSlideParams {
            lag_prior_m: 0.0,
            ..BeatSlideParams::default()
        }
    }

    #[test]
    fn a_mark_felt_beyond_the_arrays_end_moves_over_the_artery_and_marks_there() {
        let (located, moves, t) = mark_with(lagless(), |z| Some(beside(z)));
        // One move, along +z, to bring the artery `REPLACE_SHORT_M` short of the centre
        // (the first fit, from a flank, says only roughly how far).
        assert_eq!(moves.len(), 1, "{moves:?}");
        let dz = moves[0].z_m;
        assert!(moves[0].x_m.abs() < 1e-12, "{moves:?}");
        assert!(
            (dz - (BESIDE_M - REPLACE_SHORT_M)).abs() < 0.002,
            "moved {dz} m"
        );
        // The point is where the artery is, as the mark over it felt it.
        let p = located.expect("a point");
        assert!((p.point.z_m - BESIDE_M).abs() < 3e-4, "{p:?}");
        assert!((1.0..8.0).contains(&p.element), "{p:?}");
        // The seed's placement is the surgeon's, not where the move put the sensor.
        assert_eq!(t.seed_sensors.last().map(|s| s.z_m), Some(0.0));
        assert!(t.replaced.is_none());
    }

    #[test]
    fn an_artery_felt_on_the_far_half_after_the_move_leaves_the_placements_mark() {
        // After the move a pulse shows near the array's other end: not the artery the
        // flank promised. The placement's own mark (a flank's, extrapolated) stands.
        let (located, moves, _) = mark_with(lagless(), |z| {
            Some(if z.abs() < 1e-9 { beside(z) } else { 1.0 })
        });
        assert_eq!(moves.len(), 1, "{moves:?}");
        let p = located.expect("a point");
        assert!(p.element > (ELEMENTS - 1) as f64, "{p:?}");
        assert!(p.point.z_m > 0.009, "{p:?}");
    }

    #[test]
    fn nothing_felt_after_the_move_leaves_the_placements_mark() {
        let params = BeatSlideParams {
            mark_max_window_s: 8.0,
            ..lagless()
        };
        let (located, moves, _) = mark_with(params, |z| (z.abs() < 1e-9).then(|| beside(z)));
        assert_eq!(moves.len(), 1, "{moves:?}");
        let p = located.expect("the placement's point, not a miss");
        assert!(
            p.element > (ELEMENTS - 1) as f64 && p.point.z_m > 0.009,
            "{p:?}"
        );
    }

    #[test]
    fn an_artery_under_the_array_is_marked_where_it_is_placed() {
        let (located, moves, _) = mark_with(lagless(), |_| Some(6.0));
        assert!(moves.is_empty(), "{moves:?}");
        let p = located.expect("a point");
        assert!((p.point.z_m - 0.003).abs() < 3e-4, "{p:?}");
    }
}
