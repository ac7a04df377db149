//! The tracker under bad and awkward input: non-finite and dropped frames, a sensor that
//! is not at rest, and no allocation per frame.

#![allow(unsafe_code)] // The counting allocator below; nothing else.

extern crate pulsetrack_control as control;

mod support;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use control::frames::SurfacePoint;
use control::tracker::seed2002::{Seed2002, Seed2002Params};
use control::tracker::{
    EndReason, MotionCommand, TrackLimit, Tracker, TrackerEvent, TrackerInput, TrackerPhase,
};
use support::world::{ArteryPath, Mover, World};

/// Counts allocations made by the current thread.
struct CountingAllocator;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator unchanged; only counts calls.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

fn tracker() -> Seed2002 {
    Seed2002::new(Seed2002Params::default(), Default::default()).expect("default params")
}

fn straight_world(seed: u64) -> World {
    World::seed_bench(
        ArteryPath::straight(SurfacePoint::new(-0.03, 0.0), 0.0, 0.4),
        seed,
    )
}

#[test]
fn bad_frames_restart_the_acquisition_and_never_panic() {
    let mut world = straight_world(1);
    let mut t = tracker();
    let at = SurfacePoint::new(0.0, 0.0);
    t.mark().expect("mark");
    let mut result = None;
    for k in 0..2000 {
        let mut frame = world.frame(&at);
        if k == 100 {
            frame.force_n[3] = f64::NAN;
        }
        if k == 200 {
            frame.t_s = f64::INFINITY;
        }
        if k == 300 {
            // A dropped frame: the sequence jumps.
            frame.seq += 5;
        }
        let out = t.step(&TrackerInput {
            frame: &frame,
            sensor: at,
            settled: true,
            loaded_sensor: None,
        });
        assert_eq!(out.motion, MotionCommand::Hold);
        if let Some(e @ (TrackerEvent::Located(_) | TrackerEvent::Missed { .. })) = out.event {
            result = Some((k, e));
            break;
        }
    }
    let (k, e) = result.expect("the mark completes after the bad frames");
    assert!(matches!(e, TrackerEvent::Located(_)), "{e:?}");
    // Refused: the two non-finite frames, the jump ahead and the jump back to the
    // world's own numbering. The 4 s window restarts at the frame after the jump back.
    assert_eq!(t.rejected_frames(), 4);
    assert!(k >= 301 + 400 - 1, "completed at frame {k}");
}

#[test]
fn no_sampling_while_the_sensor_is_not_at_rest() {
    let mut world = straight_world(2);
    let mut t = tracker();
    let at = SurfacePoint::new(0.0, 0.0);
    t.mark().expect("mark");
    // Unsettled for 1000 frames (10 s): nothing is acquired.
    for _ in 0..1000 {
        let frame = world.frame(&at);
        let out = t.step(&TrackerInput {
            frame: &frame,
            sensor: at,
            settled: false,
            loaded_sensor: None,
        });
        assert_eq!(out.event, None);
    }
    assert_eq!(t.phase(), TrackerPhase::Marking);
    // A settle that breaks after 3.5 s restarts the 4 s window.
    let mut done = None;
    for k in 0..2000 {
        let frame = world.frame(&at);
        let out = t.step(&TrackerInput {
            frame: &frame,
            sensor: at,
            settled: k != 350,
            loaded_sensor: None,
        });
        // The acquisition's first event (the new pulse period) comes on the frame that
        // completes the window.
        if out.event.is_some() {
            done = Some(k);
            break;
        }
    }
    assert_eq!(done, Some(351 + 400 - 1));
}

#[test]
fn stepping_does_not_allocate() {
    let mut world = straight_world(3);
    let mut t = tracker();
    let mut mover = Mover::at(SurfacePoint::new(0.0, 0.0));
    let mut during_steps = 0;
    let mut frames = 0;
    let mut step = |t: &mut Seed2002, world: &mut World, mover: &mut Mover| {
        let frame = world.frame(&mover.position);
        let input = TrackerInput {
            frame: &frame,
            sensor: mover.position,
            settled: mover.settled(),
            loaded_sensor: None,
        };
        let before = allocations();
        let out = t.step(&input);
        during_steps += allocations() - before;
        frames += 1;
        mover.command(&out.motion);
        mover.advance(0.01);
        out.event
    };
    for seed in [SurfacePoint::new(0.0, 0.0), SurfacePoint::new(0.015, 0.0)] {
        mover = Mover::at(seed);
        t.mark().expect("mark");
        while !matches!(
            step(&mut t, &mut world, &mut mover),
            Some(TrackerEvent::Located(_))
        ) {}
    }
    t.start(TrackLimit {
        length_m: Some(0.08),
    })
    .expect("start");
    loop {
        if let Some(TrackerEvent::Finished { reason, .. }) = step(&mut t, &mut world, &mut mover) {
            assert_eq!(reason, EndReason::LengthReached);
            break;
        }
    }
    assert!(frames > 2000, "a real run: {frames} frames");
    // The counter does see this thread's allocations.
    let before = allocations();
    let probe = std::hint::black_box(vec![0u8; 64]);
    assert!(allocations() > before && probe.len() == 64);
    assert_eq!(during_steps, 0, "allocations inside Tracker::step");
}
