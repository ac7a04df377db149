//! A pulse too weak for `beatslide`'s windows, on synthetic frames: found by listening at a
//! mark, tracked by listening at stops, and never found in noise alone.

use super::*;
use crate::signal::kernel_fit::element_kernel;
use crate::signal::weak_pulse::generic_pressure;
use crate::test_heart::{BeatCursor, beats};
use crate::test_normals::Normals;
use crate::tracker::Tracker;
use crate::types::{ELEMENTS, TactileFrame};

const NOISE_N: f64 = 0.012;
const PERIOD_S: f64 = 1.0 / 1.1;

/// A straight artery along x at `z_m` pulsing `amplitude_n` at the kernel's peak (0:
/// none) under Gaussian element noise of 12 mN, and an arm that moves the sensor at the
/// commanded speed, at rest whenever it is not moving.
struct Bench {
    tracker: BeatSlide,
    sensor: SurfacePoint,
    settled: bool,
    seq: u64,
    noise: Normals,
    heart: BeatCursor,
    z_m: f64,
    amplitude_n: f64,
    events: Vec<TrackerEvent>,
}

impl Bench {
    fn new(params: BeatSlideParams, z_m: f64, amplitude_n: f64, seed: u64) -> Self {
        let mut noise = Normals::new(seed);
        let heart = BeatCursor::new(beats(PERIOD_S, 3000.0, &mut noise));
        Self {
            tracker: BeatSlide::new(params, ArrayGeometry::default()).expect("params"),
            sensor: SurfacePoint::new(0.0, 0.0),
            settled: true,
            seq: 0,
            noise,
            heart,
            z_m,
            amplitude_n,
            events: Vec::new(),
        }
    }

    fn frame(&mut self) -> TactileFrame {
        let fs = 100.0;
        let t_s = self.seq as f64 / fs;
        let pulse = self
            .heart
            .at(t_s)
            .map_or(0.0, |(onset, rr)| generic_pressure(t_s - onset, rr));
        let c = 4.5 + (self.z_m - self.sensor.z_m) / 0.002;
        let force_n: [f64; ELEMENTS] = std::array::from_fn(|e| {
            let felt =
                self.amplitude_n * pulse * element_kernel((e as f64 - c) * 0.002, 0.005, 0.002);
            0.4 + felt + NOISE_N * self.noise.next()
        });
        let frame = TactileFrame {
            t_s,
            seq: self.seq,
            force_n,
        };
        self.seq += 1;
        frame
    }

    /// Step until `done` says so of an event, or `limit_s` of frames; the event that ended it.
    fn run(&mut self, limit_s: f64, done: impl Fn(&TrackerEvent) -> bool) -> Option<TrackerEvent> {
        for _ in 0..(limit_s * 100.0) as u64 {
            let frame = self.frame();
            let out = self.tracker.step(&TrackerInput {
                frame: &frame,
                sensor: self.sensor,
                settled: self.settled,
                loaded_sensor: None,
            });
            // The arm moves at the commanded speed and stops where it is told to hold.
            self.settled = true;
            if let MotionCommand::MoveTo { target, speed_m_s } = out.motion {
                let d = target.distance_to(&self.sensor);
                if d > 1e-9 {
                    let step = (speed_m_s / 100.0).min(d);
                    self.sensor = SurfacePoint::new(
                        self.sensor.x_m + (target.x_m - self.sensor.x_m) * step / d,
                        self.sensor.z_m + (target.z_m - self.sensor.z_m) * step / d,
                    );
                    self.settled = false;
                }
            }
            if let Some(e) = out.event {
                self.events.push(e);
                if done(&e) {
                    return Some(e);
                }
            }
        }
        None
    }

    fn mark(&mut self, at: SurfacePoint) -> Option<TrackerEvent> {
        self.sensor = at;
        self.tracker.mark().expect("seeding");
        self.run(700.0, |e| {
            matches!(
                e,
                TrackerEvent::Located(LocatedPoint { seed: true, .. })
                    | TrackerEvent::Missed { .. }
            )
        })
    }

    fn listens(&self) -> Vec<(f64, f64, f64)> {
        self.events
            .iter()
            .filter_map(|e| match *e {
                TrackerEvent::Listening(p) => Some((p.snr, p.snr_needed, p.beats)),
                _ => None,
            })
            .collect()
    }
}

/// A third of the noise SD at the kernel's peak: the usual mark's 40 s window does not show
/// it (at 5 mN it sometimes does), listening finds it in 1-4 minutes.
const WEAK_N: f64 = 0.004;

/// The test's arm puts the sensor where it is told, with no lag behind its moves.
fn lagless() -> BeatSlideParams {
    BeatSlideParams {
        lag_prior_m: 0.0,
        ..BeatSlideParams::default()
    }
}

#[test]
fn a_pulse_too_weak_for_a_window_is_found_by_listening_and_seeds_the_track() {
    let mut bench = Bench::new(lagless(), 0.002, WEAK_N, 5);
    let seed = bench.mark(SurfacePoint::new(0.0, 0.0));
    let Some(TrackerEvent::Located(p)) = seed else {
        panic!("no seed: {seed:?} after {:?}", bench.listens().last());
    };
    // Found by listening, after the usual window had given up.
    let listens = bench.listens();
    assert!(!listens.is_empty());
    assert!(p.t_s > 0.0 && bench.seq as f64 / 100.0 > 40.0, "{p:?}");
    // Progress each segment, one SNR needed throughout, the beats weighed growing.
    assert!(listens.windows(2).all(|w| w[1].1 == w[0].1));
    assert!(listens.last().map(|l| l.2) > listens.first().map(|l| l.2));
    // In place, within a millimetre, and with an SD that says so.
    assert!((p.point.z_m - 0.002).abs() < 0.001, "{p:?}");
    let sd = p.sd_m.expect("an SD");
    assert!(sd > 0.0 && sd < 0.002, "{p:?}");
    assert!(bench.tracker.weak_artery);
    assert_eq!(bench.tracker.phase(), TrackerPhase::Seeding { seeds: 1 });
}

#[test]
fn noise_alone_is_listened_to_until_the_limit_and_misses() {
    let params = BeatSlideParams {
        weak_limit_s: 90.0,
        ..BeatSlideParams::default()
    };
    let mut bench = Bench::new(params, 0.0, 0.0, 11);
    let end = bench.mark(SurfacePoint::new(0.0, 0.0));
    assert!(matches!(end, Some(TrackerEvent::Missed { .. })), "{end:?}");
    // At the limit, not before.
    let t = bench.seq as f64 / 100.0;
    assert!((90.0..95.0).contains(&t), "missed at {t} s");
    assert!(!bench.listens().is_empty());
    assert!(!bench.tracker.weak_artery);
    assert_eq!(bench.tracker.phase(), TrackerPhase::Seeding { seeds: 0 });
}

#[test]
fn listening_is_off_at_zero_and_a_mark_misses_at_its_longest_window() {
    let params = BeatSlideParams {
        weak_limit_s: 0.0,
        ..BeatSlideParams::default()
    };
    let mut bench = Bench::new(params, 0.0, 0.0, 11);
    let end = bench.mark(SurfacePoint::new(0.0, 0.0));
    assert!(matches!(end, Some(TrackerEvent::Missed { .. })), "{end:?}");
    assert!(bench.listens().is_empty());
    assert!(bench.seq as f64 / 100.0 < 45.0);
}

#[test]
fn a_weak_artery_is_tracked_by_listening_at_stops_and_every_point_is_on_it() {
    let mut bench = Bench::new(lagless(), 0.001, WEAK_N, 23);
    for x in [0.0, 0.008] {
        let seed = bench.mark(SurfacePoint::new(x, 0.0));
        assert!(matches!(seed, Some(TrackerEvent::Located(_))), "{seed:?}");
    }
    bench
        .tracker
        .start(TrackLimit {
            length_m: Some(0.02),
        })
        .expect("seeded");
    let end = bench.run(3000.0, |e| matches!(e, TrackerEvent::Finished { .. }));
    let story: Vec<&TrackerEvent> = bench
        .events
        .iter()
        .filter(|e| !matches!(e, TrackerEvent::Listening(_)))
        .collect();
    assert!(
        matches!(
            end,
            Some(TrackerEvent::Finished {
                reason: EndReason::LengthReached,
                ..
            })
        ),
        "{end:?} after {story:?}, last miss {:?}",
        bench.tracker.last_miss
    );
    let points: Vec<LocatedPoint> = bench
        .events
        .iter()
        .filter_map(|e| match e {
            TrackerEvent::Located(p) if !p.seed => Some(*p),
            _ => None,
        })
        .collect();
    assert!(!points.is_empty());
    for p in &points {
        assert!((p.point.z_m - 0.001).abs() < FALSE_POINT_M, "{p:?}");
    }
    // Stops a step apart along the artery.
    assert!(
        points
            .windows(2)
            .all(|w| w[1].point.x_m > w[0].point.x_m + 0.002)
    );
}

#[test]
fn weak_settings_out_of_range_are_refused_by_name() {
    for (params, name) in [
        (
            BeatSlideParams {
                weak_limit_s: 900.0,
                ..BeatSlideParams::default()
            },
            "weak_limit_s",
        ),
        (
            BeatSlideParams {
                weak_false_alarm: 0.02,
                ..BeatSlideParams::default()
            },
            "weak_false_alarm",
        ),
        (
            BeatSlideParams {
                weak_step_m: 0.05,
                ..BeatSlideParams::default()
            },
            "weak_step_m",
        ),
    ] {
        let e = BeatSlide::new(params, ArrayGeometry::default()).expect_err("refused");
        assert!(e.0.contains(name), "{e}");
    }
    // Another array than the shipped table's: listening is off, the tracker runs.
    let other = ArrayGeometry {
        pitch_m: 0.003,
        ..ArrayGeometry::default()
    };
    let t = BeatSlide::new(BeatSlideParams::default(), other).expect("runs");
    assert!(!t.can_listen());
}
