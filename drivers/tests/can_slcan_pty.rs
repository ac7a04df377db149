//! The CAN driver over a real tty: the slcan adapter talking to the emulated Phantom
//! amplifiers on a pseudo-terminal. Enable, torque moves the joints the right way, e-stop and
//! bus-off fault and stop commands.

use pulsetrack_drivers as drivers;

use std::sync::Arc;
use std::time::{Duration, Instant};

use config::schema::CanJoints;
use control::ports::Manipulator;
use control::types::{JointState, JointTorques};
use drivers::MonotonicClock;
use drivers::can::phantom_emulator::{PhantomEmulator, PhantomEmulatorSettings};
use drivers::can::slcan::SlcanAdapter;
use drivers::can::{CanError, DriveState, Fault, PhantomCan};

const PATIENCE: Duration = Duration::from_secs(30);

fn path(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("pulsetrack-can-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn settings() -> CanJoints {
    CanJoints {
        // A pty on a busy test machine delivers feedback in bursts; this test is about the
        // protocol, not the 5 ms the rig keeps.
        feedback_timeout_s: 1.0,
        ..CanJoints::default()
    }
}

/// Run a 1 kHz-ish loop until `done` says so; every cycle reads and commands `torque`.
fn run_until(
    arm: &mut PhantomCan<SlcanAdapter>,
    torque: [f64; 3],
    mut done: impl FnMut(&Result<JointState, CanError>, &DriveState) -> bool,
) -> Result<JointState, CanError> {
    let start = Instant::now();
    loop {
        let r = arm.read_joints();
        let _ = arm.write_torques(&JointTorques { torque_nm: torque });
        if done(&r, arm.state()) {
            return r;
        }
        assert!(
            start.elapsed() < PATIENCE,
            "gave up; state {:?}, last {r:?}",
            arm.state()
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn torque_moves_the_emulated_arm_and_faults_stop_it() {
    let p = path("slcan0");
    let emu = PhantomEmulator::start(PhantomEmulatorSettings::new(&p)).expect("emulator");
    let adapter = SlcanAdapter::open(&p.to_string_lossy(), 115_200, 1_000_000).expect("adapter");
    let mut arm = PhantomCan::new(adapter, &settings(), Arc::new(MonotonicClock::new()));

    let start = run_until(&mut arm, [0.0; 3], |r, _| r.is_ok());
    arm.enable().expect("enable");
    let _ = run_until(&mut arm, [0.0; 3], |_, s| *s == DriveState::Enabled);

    // Positive torque on joint 0, negative on joint 1: they turn that way.
    let moved = run_until(&mut arm, [0.2, -0.2, 0.0], |r, _| {
        r.as_ref().is_ok_and(|js| {
            js.position_rad[0] - start.as_ref().map_or(0.0, |s| s.position_rad[0]) > 0.05
        })
    })
    .expect("state");
    let s0 = start.expect("state");
    assert!(moved.position_rad[1] < s0.position_rad[1] - 0.01);
    assert!(moved.velocity_rad_s[0] > 0.0 && moved.velocity_rad_s[1] < 0.0);
    assert!((moved.position_rad[2] - s0.position_rad[2]).abs() < 0.01);

    // E-stop: the amplifiers flag it, the driver faults.
    emu.estop(true);
    let r = run_until(&mut arm, [0.2, -0.2, 0.0], |_, s| {
        matches!(s, DriveState::Fault(_))
    });
    assert!(
        matches!(r, Err(CanError::Faulted(Fault::EStop { .. }))),
        "{r:?}"
    );
    match arm.enable() {
        Err(CanError::CannotEnable(why)) => assert!(why.contains("e-stop"), "{why}"),
        other => panic!("{other:?}"),
    }
    emu.estop(false);
    // Enabling is refused until feedback without the e-stop flag has arrived.
    let deadline = Instant::now() + PATIENCE;
    while arm.enable().is_err() {
        assert!(Instant::now() < deadline);
        let _ = arm.read_joints();
        std::thread::sleep(Duration::from_millis(1));
    }
    let _ = run_until(&mut arm, [0.0; 3], |_, s| *s == DriveState::Enabled);

    // Bus-off reported by the adapter's status flags.
    emu.bus_off();
    let r = run_until(&mut arm, [0.1; 3], |_, s| matches!(s, DriveState::Fault(_)));
    assert!(
        matches!(
            r,
            Err(CanError::Faulted(Fault::BusOff { .. })
                | CanError::Faulted(Fault::FeedbackTimeout { .. }))
        ),
        "{r:?}"
    );
    emu.stop().expect("emulator ran cleanly");
}

#[test]
fn an_unplugged_slcan_adapter_faults_and_recover_reopens_it_when_it_is_back() {
    let p = path("slcan-unplug");
    let emu = PhantomEmulator::start(PhantomEmulatorSettings::new(&p)).expect("emulator");
    let adapter =
        SlcanAdapter::open(&p.display().to_string(), 115_200, 1_000_000).expect("open slcan");
    let mut arm = PhantomCan::new(adapter, &settings(), Arc::new(MonotonicClock::new()));
    run_until(&mut arm, [0.0; 3], |r, _| r.is_ok()).expect("feedback");
    // Pulled out: the pty closes and the stable path goes.
    drop(emu);
    let r = run_until(&mut arm, [0.0; 3], |_, s| matches!(s, DriveState::Fault(_)));
    match (r, arm.state()) {
        (Err(CanError::Faulted(_)), DriveState::Fault(Fault::Adapter { .. })) => {}
        (r, s) => panic!("{r:?} in {s:?}"),
    }
    let link = p.display().to_string();
    match arm.recover() {
        Err(CanError::NotRecovered(why)) => assert!(
            why.contains(&format!("CAN adapter slcan {link} not available")),
            "{why}"
        ),
        other => panic!("{other:?}"),
    }
    // Plugged in again: a new pty behind the same path.
    let _emu = PhantomEmulator::start(PhantomEmulatorSettings::new(&p)).expect("emulator");
    let start = Instant::now();
    loop {
        match arm.recover() {
            Ok(()) => break,
            Err(CanError::NotRecovered(why)) => {
                assert!(start.elapsed() < PATIENCE, "never recovered: {why}")
            }
            Err(e) => panic!("{e:?}"),
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    assert_eq!(*arm.state(), DriveState::Disabled);
    arm.enable().expect("enable after reopening");
    run_until(&mut arm, [0.0; 3], |_, s| *s == DriveState::Enabled).expect("enabled");
}
