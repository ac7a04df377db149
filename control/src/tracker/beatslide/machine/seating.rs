//! `beatslide` at its first placement: mark it from both sides, so that where the sensor
//! trails the robot cancels out.
//!
//! The rod comes down on the tissue bent by the instrument's weight, and friction holds the
//! tip where it touched; at rest the sensor can lie 3-4 mm from where the kinematics put it,
//! in a direction nothing the robot measured tells, and a shifted artery looks the same on
//! the array (docs/tracker-beatslide.md, "The first placement"). Modelling that rest
//! deflection does not work: after a short stroke the sensor rests nearer the belief than
//! the play operator of `drag.rs` says (0.6 mm against its 1.5 mm, traced on the 145 mm
//! arc), and the lag itself differs from rig to rig. What does work without a model is what
//! a machinist does against backlash: come to the same believed point once from each side
//! and take the middle. So the first mark is a stroke of `seat_stroke_m` along +z (the
//! array's axis, across which the array measures) and back, a mark; the same along -z, a
//! second mark; and the seed point is their midpoint. The strokes also wipe out the touchdown
//! bend, whatever its direction. What is assumed is only that the rod gives way alike both
//! ways; the two marks' difference (twice the rest deflection) is kept as uncertainty in
//! part.

use super::*;

/// A stroke that does not arrive within this long is given up and the mark made where the
/// sensor is, s (a stroke takes about `2 × seat_stroke_m / return_speed_m_s`).
const SEAT_TIMEOUT_S: f64 = 20.0;

/// Share of half the two sides' difference (the rest deflection) kept as the midpoint's
/// uncertainty, for a rod that gives way a little more one way than the other.
const ASYMMETRY: f64 = 0.2;

/// One side's mark: the artery point as the robot believed it, and its SD.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SideMark {
    pub raw: SurfacePoint,
    pub sd_m: f64,
}

/// What a mark at the first placement is.
pub(super) enum SeatedMark {
    /// No seating strokes were made: the mark stands as it is.
    NotSeated,
    /// The first side's: kept, and the other side's stroke begun.
    OtherSide,
    /// Both sides': their midpoint and its SD.
    Both { raw: SurfacePoint, sd_m: f64 },
}

impl BeatSlide {
    /// Begin the first mark with a seating stroke when one can be made.
    pub(super) fn step_seating(
        &mut self,
        input: &TrackerInput<'_>,
        plan: Option<Stroke>,
        frames: u64,
    ) {
        let t = input.frame.t_s;
        let Some(stroke) = plan else {
            let stroke_m = self.params.seat_stroke_m;
            if stroke_m <= 0.0 || !input.sensor.is_finite() {
                // Mark from this frame on, as if no stroke had been planned.
                self.begin_marking();
                self.step_marking(input, None, self.params.mark_window_s);
                return;
            }
            let home = input.sensor;
            self.seat_home = Some(home);
            self.first_side = None;
            self.state = State::Seating {
                plan: Some(Stroke::to_side(home, stroke_m, t)),
                frames: 0,
            };
            return;
        };
        if t - stroke.since_s > SEAT_TIMEOUT_S {
            // Given up: the mark is made where the sensor is, and stands alone.
            self.seat_home = None;
            self.first_side = None;
            self.begin_marking();
            return;
        }
        if frames > 0 && input.settled {
            if stroke.leg == 0 {
                self.state = State::Seating {
                    plan: Some(Stroke { leg: 1, ..stroke }),
                    frames: 0,
                };
            } else {
                self.begin_marking();
            }
            return;
        }
        self.state = State::Seating {
            plan: Some(stroke),
            frames: frames.saturating_add(1),
        };
    }

    /// Take a successful mark at the first placement: keep the first side's and stroke to
    /// the other, or combine the two.
    pub(super) fn seated_mark(&mut self, side: SideMark, t: f64) -> SeatedMark {
        let Some(home) = self.seat_home.filter(|_| self.seeds.is_empty()) else {
            return SeatedMark::NotSeated;
        };
        match self.first_side.take() {
            None => {
                self.first_side = Some(side);
                self.state = State::Seating {
                    plan: Some(Stroke::to_side(home, -self.params.seat_stroke_m, t)),
                    frames: 0,
                };
                SeatedMark::OtherSide
            }
            Some(first) => {
                self.seat_home = None;
                // At rest after the strokes the sensor lies near the middle, not a full lag
                // behind the last stroke as the play operator would have it: the lag's
                // direction starts unknown again, as at a placement without strokes (the
                // move to the next placement then sets it).
                self.drag.forget_direction();
                let raw = SurfacePoint::new(
                    0.5 * (first.raw.x_m + side.raw.x_m),
                    0.5 * (first.raw.z_m + side.raw.z_m),
                );
                let half_gap = 0.5 * first.raw.distance_to(&side.raw);
                let sd_m = (0.5 * first.sd_m.hypot(side.sd_m)).hypot(ASYMMETRY * half_gap);
                SeatedMark::Both { raw, sd_m }
            }
        }
    }

    pub(super) fn begin_marking(&mut self) {
        self.state = State::Marking {
            since_s: None,
            window_s: self.params.mark_window_s,
        };
    }
}

/// A seating stroke: to `back` (leg 0), then to `home` (leg 1); begun at `since_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Stroke {
    pub back: SurfacePoint,
    pub home: SurfacePoint,
    pub leg: u8,
    pub since_s: f64,
}

impl Stroke {
    /// Out `dz_m` along z from `home` and back.
    fn to_side(home: SurfacePoint, dz_m: f64, since_s: f64) -> Self {
        Self {
            back: SurfacePoint::new(home.x_m, home.z_m + dz_m),
            home,
            leg: 0,
            since_s,
        }
    }

    pub fn target(&self) -> SurfacePoint {
        if self.leg == 0 { self.back } else { self.home }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::TactileFrame;

    fn rigid() -> BeatSlide {
        let params = BeatSlideParams {
            tilt_deflection: 0.0,
            seat_stroke_m: 0.008,
            ..BeatSlideParams::default()
        };
        BeatSlide::new(params, ArrayGeometry::default()).expect("default params")
    }

    /// Step at `t_s` with the robot believing the sensor at `at`.
    fn step(t: &mut BeatSlide, t_s: f64, at: SurfacePoint, settled: bool) -> MotionCommand {
        let frame = TactileFrame {
            t_s,
            seq: (t_s * 100.0) as u64,
            force_n: [0.0; crate::types::ELEMENTS],
        };
        t.step(&TrackerInput {
            frame: &frame,
            sensor: at,
            settled,
            loaded_sensor: None,
        })
        .motion
    }

    fn target(m: MotionCommand) -> SurfacePoint {
        match m {
            MotionCommand::MoveTo { target, .. } => target,
            MotionCommand::Hold => panic!("expected a move, got a hold"),
        }
    }

    #[test]
    fn the_first_mark_strokes_out_along_z_and_back_then_marks() {
        let mut t = rigid();
        let home = SurfacePoint::new(0.01, -0.01);
        t.mark().expect("seeding");
        assert_eq!(t.phase(), TrackerPhase::Marking);
        // No approach is needed: the first leg goes `seat_stroke_m` along +z.
        let out = target(step(&mut t, 0.0, home, true));
        assert!((out.x_m - home.x_m).abs() < 1e-15, "{out:?}");
        assert!(
            (out.z_m - (home.z_m + t.params.seat_stroke_m)).abs() < 1e-15,
            "{out:?}"
        );
        // Moving: still the first leg; arrived: the second, home.
        assert_eq!(target(step(&mut t, 0.01, home, false)), out);
        assert_eq!(target(step(&mut t, 0.02, out, true)), home);
        // Arrived home: the mark itself, at rest.
        assert_eq!(step(&mut t, 0.03, out, false), target_move(home, &t));
        assert_eq!(step(&mut t, 0.04, home, true), MotionCommand::Hold);
        assert!(matches!(t.state, State::Marking { .. }), "{:?}", t.state);
        assert_eq!(t.phase(), TrackerPhase::Marking);
    }

    fn side(z_m: f64, sd_m: f64) -> SideMark {
        SideMark {
            raw: SurfacePoint::new(0.01, z_m),
            sd_m,
        }
    }

    #[test]
    fn the_two_sides_marks_are_combined_at_their_midpoint() {
        let mut t = rigid();
        let home = SurfacePoint::new(0.01, 0.0);
        t.mark().expect("seeding");
        step(&mut t, 0.0, home, true);
        // The first side's mark is kept and the stroke to the other side begins.
        assert!(matches!(
            t.seated_mark(side(0.0016, 3e-4), 1.0),
            SeatedMark::OtherSide
        ));
        let other = target(step(&mut t, 1.0, home, true));
        assert!((other.z_m - (home.z_m - t.params.seat_stroke_m)).abs() < 1e-15);
        // The second: the midpoint, the SDs averaged, and a share of the deflection.
        let SeatedMark::Both { raw, sd_m } = t.seated_mark(side(-0.0014, 4e-4), 2.0) else {
            panic!("expected both sides");
        };
        assert!((raw.z_m - 0.0001).abs() < 1e-12 && (raw.x_m - 0.01).abs() < 1e-15);
        let expected = (0.5 * 5e-4f64).hypot(ASYMMETRY * 0.0015);
        assert!((sd_m - expected).abs() < 1e-12, "{sd_m} vs {expected}");
        // Done: a later mark stands as it is.
        assert!(matches!(
            t.seated_mark(side(0.0, 3e-4), 3.0),
            SeatedMark::NotSeated
        ));
        assert_eq!(t.drag.dir(), [0.0, 0.0]);
    }

    fn target_move(at: SurfacePoint, t: &BeatSlide) -> MotionCommand {
        MotionCommand::MoveTo {
            target: at,
            speed_m_s: t.params.return_speed_m_s,
        }
    }

    #[test]
    fn no_stroke_when_switched_off_and_too_long_a_stroke_refused() {
        let home = SurfacePoint::new(0.01, 0.0);
        let mut off = BeatSlide::new(
            BeatSlideParams {
                seat_stroke_m: 0.0,
                ..BeatSlideParams::default()
            },
            ArrayGeometry::default(),
        )
        .expect("params");
        off.mark().expect("seeding");
        assert_eq!(step(&mut off, 0.0, home, true), MotionCommand::Hold);
        assert!(matches!(
            off.seated_mark(side(0.0, 3e-4), 1.0),
            SeatedMark::NotSeated
        ));
        let long = BeatSlideParams {
            seat_stroke_m: 0.2,
            ..BeatSlideParams::default()
        };
        assert!(BeatSlide::new(long, ArrayGeometry::default()).is_err());
    }

    #[test]
    fn a_stroke_that_never_arrives_is_given_up_and_the_mark_made_where_it_is() {
        let mut t = rigid();
        let home = SurfacePoint::new(0.01, 0.0);
        t.mark().expect("seeding");
        let mut now = 0.0;
        let mut motion = step(&mut t, now, home, true);
        while matches!(motion, MotionCommand::MoveTo { .. }) && now < 2.0 * SEAT_TIMEOUT_S {
            now += 0.01;
            motion = step(&mut t, now, home, false);
        }
        assert_eq!(motion, MotionCommand::Hold);
        assert!((now - SEAT_TIMEOUT_S).abs() < 0.05, "gave up at {now} s");
        assert!(matches!(t.state, State::Marking { .. }), "{:?}", t.state);
        // The mark made there stands alone.
        assert!(matches!(
            t.seated_mark(side(0.0, 3e-4), now),
            SeatedMark::NotSeated
        ));
    }
}
