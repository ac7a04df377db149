//! `beatslide`'s marks under moving tissue (issue 13): a mark at rest localizes over a
//! window of several beats; with the tissue breathing under the still sensor, the window's
//! average is where the artery lay at no moment in particular. The point reported must be
//! where the artery was at the point's time, and on still tissue the mark is as before.

extern crate pulsetrack_control as control;

mod support;

use control::frames::SurfacePoint;
use control::tracker::beatslide::{BeatSlide, BeatSlideParams};
use control::tracker::{LocatedPoint, Tracker, TrackerEvent};
use support::world::{ArteryPath, Mover, World, run};

/// A mark on the artery along `x` at `z` = 0 with the sensor resting at `sensor_z_m`: the
/// period it learned, the point it reported, and the world after it.
fn mark_at(
    breathing: (f64, f64, f64),
    seed: u64,
    sensor_z_m: f64,
) -> (Option<f64>, Option<LocatedPoint>, World) {
    let mut world = World::seed_bench(
        ArteryPath::straight(SurfacePoint::new(-0.05, 0.0), 0.0, 0.1),
        seed,
    );
    world.breathing = breathing;
    let mut t = BeatSlide::new(BeatSlideParams::default(), Default::default()).expect("params");
    let mut mover = Mover::at(SurfacePoint::new(0.0, sensor_z_m));
    t.mark().expect("mark");
    let trace = run(&mut t, &mut world, &mut mover, 60_000, |e| {
        matches!(e, TrackerEvent::Located(_) | TrackerEvent::Missed { .. })
    });
    let period = trace.events.iter().find_map(|e| match e {
        TrackerEvent::Pulse { period_s, .. } => Some(*period_s),
        _ => None,
    });
    let located = trace.events.iter().find_map(|e| match e {
        TrackerEvent::Located(p) => Some(*p),
        _ => None,
    });
    (period, located, world)
}

/// The sensor resting 1 mm beside the artery.
fn mark(breathing: (f64, f64, f64), seed: u64) -> (LocatedPoint, World) {
    let (_, located, world) = mark_at(breathing, seed, 0.001);
    (located.expect("the mark found the pulse"), world)
}

#[test]
fn a_mark_under_breathing_reports_where_the_artery_was_at_the_points_time() {
    // 3 mm at 0.25 Hz, phased so that the four-second window's middle is at the peak: the
    // window's average (0) is 3 mm from the artery then.
    let breathing = (0.003, 0.25, -std::f64::consts::FRAC_PI_2);
    for seed in 1..=4 {
        let (p, world) = mark(breathing, seed);
        let there = world.tissue_shift_m(p.t_s);
        let off = p.point.z_m - there;
        assert!(
            off.abs() < 0.001,
            "seed {seed}: reported at z {:.2} mm at {:.2} s, the artery was at {:.2} mm",
            p.point.z_m * 1e3,
            p.t_s,
            there * 1e3
        );
        assert!(p.seed && p.sd_m.is_some_and(|sd| sd.is_finite()));
    }
}

#[test]
fn a_mark_on_still_tissue_reports_the_whole_window() {
    for seed in 1..=4 {
        let (p, _) = mark((0.0, 0.25, 0.0), seed);
        assert!(
            p.point.z_m.abs() < 5e-4,
            "seed {seed}: {:.2} mm off",
            p.point.z_m * 1e3
        );
        // The window's middle, not one beat's: the first mark's window is 4 s from rest.
        assert!(
            (p.t_s - 2.0).abs() < 0.1,
            "seed {seed}: reported at {:.2} s",
            p.t_s
        );
    }
}

#[test]
fn a_mark_under_strong_breathing_learns_the_heart_not_its_sidebands() {
    // 4 mm at 0.28 Hz across a 1 Hz pulse: the heart's line gets sidebands at 0.72 and
    // 1.28 Hz, which over a four-second window pass for a 0.65 Hz pulse with its second
    // harmonic, as strong as the heart's own line; only their spatial pattern (the
    // kernel's derivative, two lobes) tells them apart.
    // Before the rule, 5 of these 32 learned 1.5 s (the window starting at the motion's
    // extreme, phases pi/2 and 3 pi/2).
    let mut wrong = Vec::new();
    for f in [0.25, 0.27, 0.28, 0.3] {
        for k in 0..8u64 {
            let phase = k as f64 * std::f64::consts::FRAC_PI_4;
            let (period, p, _) = mark_at((0.004, f, phase), 1 + k, 0.0);
            let period = period.expect("the mark reports the period it learned");
            let p = p.expect("the mark answers");
            if (period - 1.0).abs() > 0.05 {
                wrong.push((f, k, period));
            }
            assert!(p.seed && p.point.z_m.is_finite());
        }
    }
    assert!(
        wrong.is_empty(),
        "periods learned at (breathing Hz, phase in eighths of a turn, period s): {wrong:?}"
    );
}
