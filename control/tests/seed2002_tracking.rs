//! The seed's tracker walked through success, backtracking and loss in a scripted world:
//! straight, oblique, reversed and curved arteries, a kink, an artery that ends, a gap.

extern crate pulsetrack_control as control;

mod support;

use control::frames::SurfacePoint;
use control::tracker::line_fit::PathLine;
use control::tracker::seed2002::{Seed2002, Seed2002Params};
use control::tracker::{
    EndReason, LocatedPoint, TrackLimit, Tracker, TrackerError, TrackerEvent, TrackerPhase,
};
use support::world::{ArteryPath, Mover, Trace, World, run};

/// Frames allowed for one trial (20 simulated minutes).
const MAX_FRAMES: usize = 120_000;

fn tracker() -> Seed2002 {
    Seed2002::new(Seed2002Params::default(), Default::default()).expect("default params")
}

fn located(events: &[TrackerEvent]) -> Vec<LocatedPoint> {
    events
        .iter()
        .filter_map(|e| match e {
            TrackerEvent::Located(p) => Some(*p),
            _ => None,
        })
        .collect()
}

fn finished(events: &[TrackerEvent]) -> Option<EndReason> {
    events.iter().find_map(|e| match e {
        TrackerEvent::Finished { reason, .. } => Some(*reason),
        _ => None,
    })
}

fn count(events: &[TrackerEvent], f: impl Fn(&TrackerEvent) -> bool) -> usize {
    events.iter().filter(|e| f(e)).count()
}

fn is_missed(e: &TrackerEvent) -> bool {
    matches!(e, TrackerEvent::Missed { .. })
}

fn is_backtracking(e: &TrackerEvent) -> bool {
    matches!(e, TrackerEvent::Backtracking { .. })
}

fn is_end(e: &TrackerEvent) -> bool {
    matches!(e, TrackerEvent::Finished { .. })
}

fn is_mark_result(e: &TrackerEvent) -> bool {
    matches!(e, TrackerEvent::Located(_) | TrackerEvent::Missed { .. })
}

/// Mark at the two placements, then start and run to the end.
fn seed_and_track(
    t: &mut Seed2002,
    world: &mut World,
    seeds: [SurfacePoint; 2],
    limit: TrackLimit,
) -> Trace {
    let mut trace = Trace::default();
    let mut mover = Mover::at(seeds[0]);
    for seed in seeds {
        mover = Mover::at(seed);
        t.mark().expect("mark while seeding");
        let part = run(t, world, &mut mover, MAX_FRAMES, is_mark_result);
        trace.events.extend(part.events);
    }
    assert_eq!(
        t.phase(),
        TrackerPhase::Seeding { seeds: 2 },
        "both seeds located: {:?}",
        trace.events
    );
    t.start(limit).expect("start after two seeds");
    let part = run(t, world, &mut mover, MAX_FRAMES, is_end);
    trace.events.extend(part.events);
    trace.targets = part.targets;
    trace.frames = part.frames;
    // Events queued behind the end come out on the next frames.
    trace
        .events
        .extend(run(t, world, &mut mover, 10, |_| false).events);
    assert!(
        matches!(t.phase(), TrackerPhase::Finished(_)),
        "tracking ended within {MAX_FRAMES} frames"
    );
    trace
}

/// Every located point lies within `tol_m` of the artery.
fn assert_on_artery(points: &[LocatedPoint], path: &ArteryPath, tol_m: f64) {
    for p in points {
        let (d, _) = path.nearest(&p.point);
        assert!(d <= tol_m, "{p:?} is {d} m from the artery");
    }
}

/// The tracker sampled only at rest: every tracked point's sensor position is exactly one
/// of the commanded targets (the scripted motion layer stops exactly on target).
fn assert_sampled_at_targets(points: &[LocatedPoint], targets: &[SurfacePoint]) {
    for p in points.iter().filter(|p| !p.seed) {
        assert!(
            targets.iter().any(|t| t.distance_to(&p.sensor) < 1e-12),
            "{p:?} was not sampled at a commanded target"
        );
    }
}

#[test]
fn follows_a_straight_artery_to_the_requested_length() {
    let path = ArteryPath::straight(SurfacePoint::new(-0.03, 0.001), 0.0, 0.4);
    let mut world = World::seed_bench(path.clone(), 1);
    let mut t = tracker();
    let seeds = [SurfacePoint::new(0.0, 0.0), SurfacePoint::new(0.015, 0.0)];
    let limit = TrackLimit {
        length_m: Some(0.12),
    };
    let trace = seed_and_track(&mut t, &mut world, seeds, limit);
    let events = &trace.events;
    assert_eq!(
        finished(events),
        Some(EndReason::LengthReached),
        "{events:?}"
    );
    let points = located(events);
    assert!(points[0].seed && points[1].seed && !points[2].seed);
    assert_on_artery(&points, &path, 0.002);
    assert_sampled_at_targets(&points, &trace.targets);
    assert!(t.path_length_m() >= 0.12);
    // No misses on a straight artery; each step 5 % longer than the one before. (Steps
    // run along the fitted line; element quantization tilts it slightly, so the advance
    // in x differs from the step by well under 0.1 %.)
    assert_eq!(count(events, is_missed), 0);
    let steps: Vec<f64> = points
        .windows(2)
        .skip(1)
        .map(|w| w[1].point.x_m - w[0].point.x_m)
        .collect();
    assert!((steps[0] - 0.015).abs() < 1e-5, "{steps:?}");
    for w in steps.windows(2) {
        assert!((w[1] / w[0] - 1.05).abs() < 1e-3, "{steps:?}");
    }
    // The pulse period was measured and reported (the world pulses at 1 Hz).
    let period = t.period_estimate_s().expect("period known");
    assert!((period - 1.0).abs() < 0.05, "{period}");
    assert!(count(events, |e| matches!(e, TrackerEvent::Pulse { .. })) > 0);
}

#[test]
fn follows_arteries_running_in_any_direction_the_array_can_cross() {
    // Oblique (20° and -30° from x) and reversed (toward -x) courses; the element line
    // stays along z, so the crossing angle stays well below 90°.
    for (heading, seed) in [(0.35f64, 2), (-0.52, 3), (std::f64::consts::PI, 4)] {
        let start = SurfacePoint::new(-0.03 * heading.cos(), -0.03 * heading.sin());
        let path = ArteryPath::straight(start, heading, 0.4);
        let mut world = World::seed_bench(path.clone(), seed);
        let mut t = tracker();
        let seeds = [path.at(0.03), path.at(0.045)];
        let limit = TrackLimit {
            length_m: Some(0.1),
        };
        let trace = seed_and_track(&mut t, &mut world, seeds, limit);
        assert_eq!(
            finished(&trace.events),
            Some(EndReason::LengthReached),
            "heading {heading}: {:?}",
            trace.events
        );
        let points = located(&trace.events);
        // An oblique crossing spreads the footprint over more elements: within 3 mm.
        assert_on_artery(&points, &path, 0.003);
        // It went the way the seeds pointed.
        let last = points.last().expect("points");
        let (_, s_last) = path.nearest(&last.point);
        assert!(
            s_last > 0.045 + 0.08,
            "heading {heading}: ended at s = {s_last}"
        );
    }
}

#[test]
fn follows_a_curved_artery() {
    // The seed's 145 mm arc over the part an element line that cannot roll can follow.
    let path = ArteryPath::arc(0.145, 0.2);
    let mut world = World::seed_bench(path.clone(), 5);
    let mut t = tracker();
    let seeds = [path.at(0.01), path.at(0.025)];
    let limit = TrackLimit {
        length_m: Some(0.09),
    };
    let trace = seed_and_track(&mut t, &mut world, seeds, limit);
    assert_eq!(
        finished(&trace.events),
        Some(EndReason::LengthReached),
        "{:?}",
        trace.events
    );
    let points = located(&trace.events);
    assert_on_artery(&points, &path, 0.003);
    assert_sampled_at_targets(&points, &trace.targets);
}

#[test]
fn backtracks_after_a_kink_and_carries_on() {
    // Straight along x, then a 45° turn: the extrapolated target overshoots the turn, the
    // pulse is missed, the tracker halves the step back toward the last point found,
    // finds the artery and continues along the new course.
    let kink = SurfacePoint::new(0.06, 0.0);
    let path = ArteryPath::polyline(vec![
        SurfacePoint::new(-0.03, 0.0),
        kink,
        SurfacePoint::new(0.06 + 0.2 * 0.5f64.sqrt(), 0.2 * 0.5f64.sqrt()),
    ]);
    let mut world = World::seed_bench(path.clone(), 6);
    let mut t = tracker();
    let seeds = [SurfacePoint::new(0.0, 0.0), SurfacePoint::new(0.02, 0.0)];
    let limit = TrackLimit {
        length_m: Some(0.15),
    };
    let trace = seed_and_track(&mut t, &mut world, seeds, limit);
    let events = &trace.events;
    assert_eq!(
        finished(events),
        Some(EndReason::LengthReached),
        "{events:?}"
    );
    let first_back = events
        .iter()
        .position(is_backtracking)
        .expect("at least one backtrack");
    assert!(
        is_missed(&events[first_back - 1]),
        "a miss precedes the backtrack"
    );
    assert!(
        events[first_back..]
            .iter()
            .any(|e| matches!(e, TrackerEvent::Located(_))),
        "found again after backtracking"
    );
    let points = located(events);
    assert_on_artery(&points, &path, 0.003);
    // It got well past the turn.
    let (_, s_last) = path.nearest(&points.last().expect("points").point);
    assert!(s_last > 0.09 + 0.05, "ended at s = {s_last}");
}

#[test]
fn loses_an_artery_that_ends_after_halving_down_to_the_minimum_step() {
    // The artery stops pulsing at x = 0.07.
    let path = ArteryPath::straight(SurfacePoint::new(-0.03, 0.0), 0.0, 0.10);
    let mut world = World::seed_bench(path.clone(), 7);
    let mut t = tracker();
    let seeds = [SurfacePoint::new(0.0, 0.0), SurfacePoint::new(0.015, 0.0)];
    let trace = seed_and_track(&mut t, &mut world, seeds, TrackLimit::default());
    let events = &trace.events;
    assert_eq!(finished(events), Some(EndReason::Lost), "{events:?}");
    let points = located(events);
    // Nothing located beyond the end (with the kernel's reach: a few mm).
    for p in &points {
        assert!(p.point.x_m < 0.07 + 0.006, "{p:?}");
    }
    // Every miss halves the step and re-targets from the last point found (its foot on
    // the line through the last four points found), toward it.
    let mut found: Vec<SurfacePoint> = Vec::new();
    let mut last_miss = None;
    let mut backtracks = 0;
    for e in events {
        match *e {
            TrackerEvent::Located(p) => found.push(p.point),
            TrackerEvent::Missed { at, .. } => last_miss = Some(at),
            TrackerEvent::Backtracking { toward, .. } => {
                let recent = &found[found.len().saturating_sub(4)..];
                let line = PathLine::fit(recent).expect("a line");
                let foot = line.at(line.along(recent.last().expect("found")));
                let missed = last_miss.expect("missed");
                let ratio = toward.distance_to(&foot) / missed.distance_to(&foot);
                assert!((ratio - 0.5).abs() < 1e-9, "{ratio}: {events:?}");
                assert!(line.across(&toward).abs() < 1e-12);
                backtracks += 1;
            }
            _ => {}
        }
    }
    let last_found = found.last().copied();
    assert!(backtracks >= 1, "{events:?}");
    // The end: the last step tried was at least the 2 mm minimum, and half of it is not
    // (within the millimetre the last point may lie off the line).
    let failed_step = last_miss
        .expect("missed")
        .distance_to(&last_found.expect("found"));
    assert!((0.002..0.005).contains(&failed_step), "{failed_step}");
    assert!(t.step_m() < 0.002);
    assert!(
        is_missed(&events[events.len() - 2]),
        "a miss ends it: {events:?}"
    );
}

#[test]
fn a_gap_without_pulse_is_backtracked_and_then_lost() {
    // The artery dives out of reach for 20 mm.
    let path = ArteryPath::straight(SurfacePoint::new(-0.03, 0.0), 0.0, 0.4);
    let mut world = World::seed_bench(path, 8);
    world.gaps.push((0.08, 0.10));
    let mut t = tracker();
    let seeds = [SurfacePoint::new(0.0, 0.0), SurfacePoint::new(0.015, 0.0)];
    let trace = seed_and_track(&mut t, &mut world, seeds, TrackLimit::default());
    let events = &trace.events;
    assert_eq!(finished(events), Some(EndReason::Lost), "{events:?}");
    assert!(count(events, is_backtracking) >= 2);
    // Every backtrack re-tried up to 7 acquisitions: at least 7 × 3 s between a target's
    // arrival and its miss. (Checked as: the run took at least that long per miss.)
    let misses = count(events, is_missed);
    assert!(trace.frames >= misses * 7 * 300);
}

#[test]
fn stop_and_the_workspace_edge_end_tracking() {
    let path = ArteryPath::straight(SurfacePoint::new(-0.03, 0.0), 0.0, 0.4);
    for stop in [true, false] {
        let mut world = World::seed_bench(path.clone(), 9);
        let mut t = tracker();
        let mut mover = Mover::at(SurfacePoint::new(0.0, 0.0));
        t.mark().expect("mark");
        run(&mut t, &mut world, &mut mover, MAX_FRAMES, is_mark_result);
        mover = Mover::at(SurfacePoint::new(0.015, 0.0));
        t.mark().expect("mark");
        run(&mut t, &mut world, &mut mover, MAX_FRAMES, is_mark_result);
        t.start(TrackLimit::default()).expect("start");
        run(&mut t, &mut world, &mut mover, 50, |_| false);
        assert_eq!(t.phase(), TrackerPhase::Tracking);
        let want = if stop {
            t.stop();
            EndReason::Stopped
        } else {
            t.target_unreachable();
            EndReason::WorkspaceEdge
        };
        assert_eq!(t.phase(), TrackerPhase::Finished(want));
        let trace = run(&mut t, &mut world, &mut mover, 5, |_| false);
        assert_eq!(finished(&trace.events), Some(want));
        assert!(trace.targets.is_empty(), "no motion after the end");
        assert!(matches!(
            t.mark(),
            Err(TrackerError::WrongPhase { verb: "mark", .. })
        ));
    }
}

#[test]
fn seeding_refuses_what_it_cannot_track() {
    let path = ArteryPath::straight(SurfacePoint::new(-0.03, 0.0), 0.0, 0.4);
    let mut world = World::seed_bench(path, 10);
    let mut t = tracker();
    assert_eq!(
        t.start(TrackLimit::default()),
        Err(TrackerError::NotSeeded { have: 0 })
    );
    // A placement far from the artery: missed, still seeding with no seeds.
    let mut mover = Mover::at(SurfacePoint::new(0.0, 0.05));
    t.mark().expect("mark");
    assert_eq!(t.phase(), TrackerPhase::Marking);
    assert!(matches!(
        t.mark(),
        Err(TrackerError::WrongPhase { verb: "mark", .. })
    ));
    let trace = run(&mut t, &mut world, &mut mover, MAX_FRAMES, is_mark_result);
    assert!(trace.events.iter().any(is_missed), "{:?}", trace.events);
    assert_eq!(t.phase(), TrackerPhase::Seeding { seeds: 0 });
    // Two placements at the same spot give no direction.
    mover = Mover::at(SurfacePoint::new(0.01, 0.0));
    for _ in 0..2 {
        t.mark().expect("mark");
        run(&mut t, &mut world, &mut mover, MAX_FRAMES, is_mark_result);
    }
    assert_eq!(t.phase(), TrackerPhase::Seeding { seeds: 2 });
    assert!(matches!(
        t.start(TrackLimit::default()),
        Err(TrackerError::SeedsTooClose { .. })
    ));
    assert!(matches!(
        t.start(TrackLimit {
            length_m: Some(-1.0)
        }),
        Err(TrackerError::BadLimit(_))
    ));
}

#[test]
fn seed_marks_report_the_artery_point_not_the_sensor_centre() {
    // The artery runs 5 mm to the side of the sensor centre: the seed point is the
    // sensor centre plus the element's offset along z.
    let path = ArteryPath::straight(SurfacePoint::new(-0.03, 0.005), 0.0, 0.4);
    let mut world = World::seed_bench(path, 11);
    let mut t = tracker();
    let mut mover = Mover::at(SurfacePoint::new(0.0, 0.0));
    t.mark().expect("mark");
    let trace = run(&mut t, &mut world, &mut mover, MAX_FRAMES, is_mark_result);
    let p = located(&trace.events)[0];
    assert!(p.seed);
    assert_eq!(p.sensor, SurfacePoint::new(0.0, 0.0));
    assert!((p.point.z_m - 0.005).abs() <= 0.001, "{p:?}");
    assert!((p.element - (4.5 + 2.5)).abs() <= 0.5, "{p:?}");
    assert!(p.amplitude_n > 0.024);
}
