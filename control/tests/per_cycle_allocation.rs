//! The per-cycle path allocates nothing: joint setpoint from the motion planner through the
//! kinematics, gravity, the PD step and the settle check, counted by a wrapping allocator.

// A counting allocator needs `unsafe impl GlobalAlloc`; it only delegates to `System`.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::Point3;
use pulsetrack_control::frames::SurfacePoint;
use pulsetrack_control::kinematics::{
    ArmModel, DEFAULT_SENSOR_OFFSET_M, DEFAULT_SURFACE_DEPTH_M, JointLimits, PhantomGeometry,
    PivotGeometry, tissue_under_pivot,
};
use pulsetrack_control::motion::{MotionParams, MotionPlanner};
use pulsetrack_control::pd::{GravityModel, PdController, PdParams, PhantomGravity, PhantomMasses};
use pulsetrack_control::types::JointState;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    // Count only on the thread under test, not the test harness's own threads.
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
fn two_thousand_cycles_allocate_nothing() {
    let pivot = PivotGeometry::default();
    let arm = ArmModel::new(
        PhantomGeometry::default(),
        JointLimits::default(),
        pivot,
        tissue_under_pivot(
            &pivot,
            DEFAULT_SENSOR_OFFSET_M,
            DEFAULT_SURFACE_DEPTH_M,
            0.0,
        ),
        DEFAULT_SENSOR_OFFSET_M,
    )
    .expect("default geometry");
    let gravity = PhantomGravity::new(&PhantomMasses::default());
    let mut pd = PdController::new(PdParams::default()).expect("default gains");
    let mut planner = MotionPlanner::new(MotionParams::default()).expect("default motion");
    planner
        .start(
            SurfacePoint::new(0.0, 0.0),
            SurfacePoint::new(0.02, 0.01),
            0.02,
            0.0,
        )
        .expect("a valid move");
    let mut q = arm
        .joints_for_sensor(&Point3::new(0.0, -0.003, 0.0))
        .expect("reachable");

    let before = ALLOCATIONS.load(Ordering::SeqCst);
    COUNTING.with(|c| c.set(true));
    let mut settled = 0;
    for k in 0..2000 {
        let t = f64::from(k) * 1e-3;
        let (p, v) = planner.setpoint(t).expect("a move is running");
        let sp = arm.joint_setpoint(&p, &v).expect("reachable setpoint");
        let state = JointState {
            t_s: t,
            position_rad: q,
            velocity_rad_s: sp.velocity_rad_s,
        };
        let g = gravity.torque_nm(&q);
        pd.step(&sp, &state, &g, 1e-3).expect("no fault");
        q = sp.position_rad;
        let believed = arm.surface_point(&q).expect("in range");
        planner.trim_toward_target(believed, 0.0, t);
        settled += usize::from(planner.settled(believed, 0.0, t));
    }
    COUNTING.with(|c| c.set(false));
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert_eq!(after - before, 0, "allocations in the per-cycle path");
    // The loop really ran the move (1.32 s) and rested at its end.
    assert!(settled > 500, "{settled}");
}
