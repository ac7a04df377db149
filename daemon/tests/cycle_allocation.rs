//! The control loop's cycle allocates nothing on its normal path: read joints, drain the
//! tactile port, stamp and send frames and joint samples, apply commands, safety, the servo
//! (motion, kinematics, PD, gravity), the torque guard, write, publish the status slot and
//! the flight recorder. Counted by a wrapping allocator on the thread under test.

// A counting allocator needs `unsafe impl GlobalAlloc`; it only delegates to `System`.
#![allow(unsafe_code)]

mod plant;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use control::frames::SurfacePoint;
use plant::{ControlCommand, ControlEvent, LoopMode, rig};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn powered_cycles_moving_and_streaming_allocate_nothing() {
    let mut r = rig();
    r.run(50);
    assert!(matches!(
        r.send(|seq| ControlCommand::Enable { seq }),
        ControlEvent::Done { .. }
    ));
    // A move is under way and frames and joint samples stream out while we count; the
    // command itself is queued before counting (the channel send is the sender's business).
    let target = SurfacePoint::new(r.start.x_m + 0.01, r.start.z_m);
    r.commands
        .try_send(ControlCommand::MoveTo {
            seq: 99,
            target,
            speed_m_s: 0.01,
        })
        .expect("queue");
    r.run(10);
    ALLOCATIONS.store(0, Ordering::SeqCst);
    COUNTING.with(|c| c.set(true));
    for _ in 0..3000 {
        r.control.cycle();
        // Keep the consumers drained as the supervisor would (outside the count).
        COUNTING.with(|c| c.set(false));
        while r.samples.try_recv().is_ok() {}
        while r.events.try_recv().is_ok() {}
        COUNTING.with(|c| c.set(true));
    }
    COUNTING.with(|c| c.set(false));
    assert_eq!(r.status().mode, LoopMode::Enabled);
    assert!(
        r.status().sensor.distance_to(&r.start) > 0.005,
        "the arm moved"
    );
    assert_eq!(
        ALLOCATIONS.load(Ordering::SeqCst),
        0,
        "allocations in 3000 cycles"
    );
}

/// The joint stop sweep's mode (`SweepStops`): its plan is built when the command arrives,
/// and every cycle after (ramps, the search, the cap, the widened limit check) allocates
/// nothing.
#[test]
fn joint_sweep_cycles_allocate_nothing() {
    let mut r = rig();
    r.run(50);
    assert!(matches!(
        r.send(|seq| ControlCommand::SweepStops {
            seq,
            targets: control::calibration::StopTargets::joints(&[0]).expect("joint 0"),
            settings: control::calibration::JointSettings::default(),
        }),
        ControlEvent::Done { .. }
    ));
    r.run(10);
    ALLOCATIONS.store(0, Ordering::SeqCst);
    COUNTING.with(|c| c.set(true));
    for _ in 0..3000 {
        r.control.cycle();
        COUNTING.with(|c| c.set(false));
        while r.samples.try_recv().is_ok() {}
        while r.events.try_recv().is_ok() {}
        COUNTING.with(|c| c.set(true));
    }
    COUNTING.with(|c| c.set(false));
    assert_eq!(r.status().mode, LoopMode::Enabled, "still sweeping");
    assert_eq!(
        ALLOCATIONS.load(Ordering::SeqCst),
        0,
        "allocations in 3000 sweep cycles"
    );
}
