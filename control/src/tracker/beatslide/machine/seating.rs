//! `beatslide` before its first mark: seat the sensor so that where it trails the robot is
//! known.
//!
//! The rod comes down on the tissue bent by the instrument's weight, and friction holds the
//! tip where it touched. A short approach to the first placement (10 mm) unloads part of
//! that bend without sliding the tip, so at the mark the sensor can rest 3-4 mm from where
//! the kinematics and the drag model put it, in a direction nothing the robot measured
//! tells; a shifted artery looks the same on the array, and the first seed point would be
//! off by it (docs/tracker-beatslide.md, "The first placement"). Sliding the sensor far
//! enough in one line brings the bend round to trail the motion (the play operator of
//! `drag.rs`), where the lag model knows it. So the first mark begins with a stroke back
//! along the approach and forward again onto the surgeon's placement; the sensor stays on
//! the line the surgeon drew it along, which is the artery's.
//!
//! With no approach seen (the sensor was put down where it is), the bend's direction is
//! not known even roughly, and no stroke is made: the mark's observation carries the lag
//! prior as uncertainty, as before.

use super::*;

/// A stroke that does not arrive within this long is given up and the mark made where the
/// sensor is, s (a stroke takes about `2 × seat_stroke_m / return_speed_m_s`).
const SEAT_TIMEOUT_S: f64 = 20.0;

/// Length of the drag direction (1 while sliding) below which the approach is taken as
/// unseen.
const SEEN_APPROACH: f64 = 0.5;

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
            let u = self.drag.dir();
            let n = u[0].hypot(u[1]);
            let stroke_m = self.params.seat_stroke_m;
            if n < SEEN_APPROACH || stroke_m <= 0.0 || !input.sensor.is_finite() {
                // Mark from this frame on, as if no stroke had been planned.
                self.begin_marking();
                self.step_marking(input, None, self.params.mark_window_s);
                return;
            }
            let home = input.sensor;
            let back = SurfacePoint::new(
                home.x_m - stroke_m * u[0] / n,
                home.z_m - stroke_m * u[1] / n,
            );
            self.state = State::Seating {
                plan: Some(Stroke {
                    back,
                    home,
                    leg: 0,
                    since_s: t,
                }),
                frames: 0,
            };
            return;
        };
        if t - stroke.since_s > SEAT_TIMEOUT_S {
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
    pub fn target(&self) -> SurfacePoint {
        if self.leg == 0 { self.back } else { self.home }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::approach::ApproachTrail;
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
    fn the_first_mark_strokes_back_along_the_approach_and_returns() {
        let mut t = rigid();
        // The surgeon slid the sensor 10 mm along +x and -z (a 45 degree approach).
        let mut trail = ApproachTrail::default();
        for k in 0..=100 {
            let s = 1e-4 * k as f64;
            trail.push(SurfacePoint::new(s, -s));
        }
        trail.hand_to(&mut t);
        let home = SurfacePoint::new(0.01, -0.01);
        t.mark().expect("seeding");
        assert_eq!(t.phase(), TrackerPhase::Marking);
        // The stroke's first leg goes back along the approach by `seat_stroke_m`.
        let back = target(step(&mut t, 0.0, home, true));
        let d = t.params.seat_stroke_m / 2f64.sqrt();
        assert!((back.x_m - (home.x_m - d)).abs() < 1e-12, "{back:?}");
        assert!((back.z_m - (home.z_m + d)).abs() < 1e-12, "{back:?}");
        // Moving: still the first leg; arrived: the second, home.
        assert_eq!(target(step(&mut t, 0.01, home, false)), back);
        assert_eq!(target(step(&mut t, 0.02, back, true)), home);
        // Arrived home: the mark itself, at rest.
        assert_eq!(step(&mut t, 0.03, back, false), target_move(home, &t));
        assert_eq!(step(&mut t, 0.04, home, true), MotionCommand::Hold);
        assert!(matches!(t.state, State::Marking { .. }), "{:?}", t.state);
        assert_eq!(t.phase(), TrackerPhase::Marking);
    }

    fn target_move(at: SurfacePoint, t: &BeatSlide) -> MotionCommand {
        MotionCommand::MoveTo {
            target: at,
            speed_m_s: t.params.return_speed_m_s,
        }
    }

    #[test]
    fn no_stroke_without_a_seen_approach_or_when_switched_off() {
        let home = SurfacePoint::new(0.01, 0.0);
        // Put down where it is: nothing says which way the rod trails.
        let mut t = rigid();
        t.mark().expect("seeding");
        assert_eq!(step(&mut t, 0.0, home, true), MotionCommand::Hold);
        assert!(matches!(t.state, State::Marking { .. }), "{:?}", t.state);
        // Switched off: no stroke even after an approach.
        let mut off = BeatSlide::new(
            BeatSlideParams {
                seat_stroke_m: 0.0,
                ..BeatSlideParams::default()
            },
            ArrayGeometry::default(),
        )
        .expect("params");
        let mut trail = ApproachTrail::default();
        for k in 0..=100 {
            trail.push(SurfacePoint::new(1e-4 * k as f64, 0.0));
        }
        trail.hand_to(&mut off);
        off.mark().expect("seeding");
        assert_eq!(step(&mut off, 0.0, home, true), MotionCommand::Hold);
        // Too long a stroke is refused as a parameter, not tried.
        let long = BeatSlideParams {
            seat_stroke_m: 0.2,
            ..BeatSlideParams::default()
        };
        assert!(BeatSlide::new(long, ArrayGeometry::default()).is_err());
    }

    #[test]
    fn a_stroke_that_never_arrives_is_given_up_and_the_mark_made_where_it_is() {
        let mut t = rigid();
        let mut trail = ApproachTrail::default();
        for k in 0..=100 {
            trail.push(SurfacePoint::new(1e-4 * k as f64, 0.0));
        }
        trail.hand_to(&mut t);
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
    }
}
