//! The CAN driver's state handling against the mock adapter: enabling, scaling, every fault
//! (bus-off, error-passive, e-stop, stale feedback, amplifier emergency, transmit overrun,
//! non-finite command) and that no queued command survives a fault.

use pulsetrack_drivers as drivers;

use std::sync::Arc;

use config::schema::CanJoints;
use control::ports::Manipulator;
use control::types::JointTorques;
use drivers::ManualClock;
use drivers::can::protocol::{ControlCommand, Message, NodeState, status};
use drivers::can::scaling::JointScaling;
use drivers::can::{
    BusCondition, BusEvent, CanError, DataFrame, DriveState, Fault, MockBus, PhantomCan,
};
use proptest::prelude::*;

struct Rig {
    bus: MockBus,
    clock: ManualClock,
    arm: PhantomCan<MockBus>,
    seq: [u8; 3],
    amp_us: u16,
}

impl Rig {
    fn new() -> Self {
        let bus = MockBus::new(64);
        let clock = ManualClock::new(100.0);
        let arm = PhantomCan::new(bus.clone(), &CanJoints::default(), Arc::new(clock.clone()));
        Self {
            bus,
            clock,
            arm,
            seq: [0; 3],
            amp_us: 0,
        }
    }

    /// One feedback frame from each amplifier, 1 ms after the previous ones.
    fn feedback(&mut self, counts: [i32; 3], st: u8) {
        self.clock.advance(0.001);
        self.amp_us = self.amp_us.wrapping_add(1000);
        for (j, &c) in counts.iter().enumerate() {
            self.seq[j] = self.seq[j].wrapping_add(1);
            let m = Message::Feedback {
                node: j as u8 + 1,
                counts: c,
                amp_time_us: self.amp_us,
                status: st,
                seq: self.seq[j],
            };
            self.bus.inject_frame(m.encode());
        }
    }

    fn enabled(mut self) -> Self {
        self.feedback([0; 3], 0);
        self.arm.read_joints().expect("feedback present");
        self.arm.enable().expect("enable");
        self.feedback([0; 3], status::ENABLED);
        self.arm.read_joints().expect("enabled");
        assert_eq!(*self.arm.state(), DriveState::Enabled);
        self.bus.transmit_pending();
        self.bus.take_wire();
        self
    }

    fn decoded(frames: &[DataFrame]) -> Vec<Message> {
        frames
            .iter()
            .filter_map(|f| Message::decode(f).ok().flatten())
            .filter(|m| !matches!(m, Message::Heartbeat { .. }))
            .collect()
    }
}

fn disable_all() -> Message {
    Message::Control {
        command: ControlCommand::Disable,
        node: 0,
    }
}

#[test]
fn enable_sequence_scaling_and_torque_frames() {
    let mut rig = Rig::new();
    // Before any feedback there is no state, and enabling is refused with a reason.
    match rig.arm.read_joints() {
        Err(CanError::NoFeedback { joint: 0, node: 1 }) => {}
        other => panic!("{other:?}"),
    }
    match rig.arm.enable() {
        Err(CanError::CannotEnable(why)) => assert!(why.contains("node 1"), "{why}"),
        other => panic!("{other:?}"),
    }

    let s = JointScaling::for_joints(&CanJoints::default());
    rig.feedback([1362, -2000, 500], 0);
    let js = rig.arm.read_joints().expect("state");
    assert!((js.position_rad[0] - 1362.0 * s[0].rad_per_count).abs() < 1e-12);
    assert!((js.position_rad[1] + 2000.0 * s[1].rad_per_count).abs() < 1e-12);
    assert_eq!(js.t_s, rig.clock.now_s_value());

    // Torques written while disabled are not applied.
    rig.arm
        .write_torques(&JointTorques {
            torque_nm: [0.1; 3],
        })
        .expect("ignored while disabled");
    assert!(Rig::decoded(&rig.bus.pending()).is_empty());

    rig.arm.enable().expect("enable");
    assert!(matches!(rig.arm.state(), DriveState::Enabling { .. }));
    let sent = Rig::decoded(&rig.bus.pending());
    assert_eq!(
        sent,
        vec![
            Message::Control {
                command: ControlCommand::ClearFault,
                node: 0
            },
            Message::Control {
                command: ControlCommand::Enable,
                node: 0
            },
        ]
    );
    // Still enabling: torques are not sent until every amplifier reports enabled.
    rig.arm
        .write_torques(&JointTorques {
            torque_nm: [0.1; 3],
        })
        .expect("ok");
    assert_eq!(Rig::decoded(&rig.bus.pending()).len(), 2);
    rig.feedback([1362, -2000, 500], status::ENABLED);
    rig.arm.read_joints().expect("state");
    assert_eq!(*rig.arm.state(), DriveState::Enabled);

    rig.bus.transmit_pending();
    rig.bus.take_wire();
    rig.arm
        .write_torques(&JointTorques {
            torque_nm: [0.2, -0.1, 5.0],
        })
        .expect("sent");
    let sent = Rig::decoded(&rig.bus.pending());
    // 0.2 N·m / 13.3 = 15.04 mN·m = 1504 counts; -0.1 / 11.2 = -893; 5 N·m clamps at 28.6 mN·m.
    let torques: Vec<(u8, i16)> = sent
        .iter()
        .map(|m| match m {
            Message::Torque { node, torque, .. } => (*node, *torque),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(torques, vec![(1, 1504), (2, -893), (3, 2860)]);
    assert_eq!(rig.arm.stats().torque_clamped, 1);
}

trait NowValue {
    fn now_s_value(&self) -> f64;
}
impl NowValue for ManualClock {
    fn now_s_value(&self) -> f64 {
        drivers::Clock::now_s(self)
    }
}

fn assert_fault_drops_queued_commands(condition: BusCondition, expect: fn(&Fault) -> bool) {
    let mut rig = Rig::new().enabled();
    // Commands queued in the controller while the bus is failing...
    for _ in 0..2 {
        rig.arm
            .write_torques(&JointTorques {
                torque_nm: [0.3; 3],
            })
            .expect("queued");
    }
    assert_eq!(Rig::decoded(&rig.bus.pending()).len(), 6);
    rig.bus.inject(BusEvent::Condition(condition));
    match rig.arm.read_joints() {
        Err(CanError::Faulted(f)) => assert!(expect(&f), "{f}"),
        other => panic!("{other:?}"),
    }
    // ...are gone: the only thing left to send is a broadcast disable.
    assert_eq!(Rig::decoded(&rig.bus.pending()), vec![disable_all()]);
    // Later commands are refused, not queued.
    assert!(matches!(
        rig.arm.write_torques(&JointTorques {
            torque_nm: [0.3; 3]
        }),
        Err(CanError::Faulted(_))
    ));
    // The bus recovers (the e-stop is released, the cable reseated): nothing old goes out.
    rig.bus.inject(BusEvent::Condition(BusCondition {
        restarted: true,
        back_to_active: true,
        ..BusCondition::default()
    }));
    rig.feedback([0; 3], 0);
    let _ = rig.arm.read_joints();
    rig.bus.transmit_pending();
    let wire = Rig::decoded(&rig.bus.wire());
    assert!(
        wire.iter().all(|m| !matches!(m, Message::Torque { .. })),
        "{wire:?}"
    );
    // Still latched until explicitly enabled.
    assert!(matches!(rig.arm.state(), DriveState::Fault(_)));
    rig.arm
        .enable()
        .expect("explicit recovery once the bus is healthy");
}

#[test]
fn bus_off_faults_and_drops_queued_frames() {
    assert_fault_drops_queued_commands(
        BusCondition {
            bus_off: true,
            ..BusCondition::default()
        },
        |f| matches!(f, Fault::BusOff { .. }),
    );
}

#[test]
fn error_passive_faults_and_drops_queued_frames() {
    assert_fault_drops_queued_commands(
        BusCondition {
            error_passive: true,
            ..BusCondition::default()
        },
        |f| matches!(f, Fault::ErrorPassive { .. }),
    );
}

#[test]
fn enable_is_refused_while_the_bus_is_off() {
    let mut rig = Rig::new().enabled();
    rig.bus.inject(BusEvent::Condition(BusCondition {
        bus_off: true,
        ..BusCondition::default()
    }));
    let _ = rig.arm.read_joints();
    rig.feedback([0; 3], 0);
    match rig.arm.enable() {
        Err(CanError::CannotEnable(why)) => assert!(why.contains("bus-off"), "{why}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn estop_faults_and_blocks_enable_until_released() {
    let mut rig = Rig::new().enabled();
    rig.arm
        .write_torques(&JointTorques {
            torque_nm: [0.1; 3],
        })
        .expect("queued");
    rig.feedback([0; 3], status::ENABLED | status::ESTOP);
    match rig.arm.read_joints() {
        Err(CanError::Faulted(Fault::EStop { joint: 0 })) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(Rig::decoded(&rig.bus.pending()), vec![disable_all()]);
    rig.feedback([0; 3], status::ESTOP);
    match rig.arm.enable() {
        Err(CanError::CannotEnable(why)) => assert!(why.contains("e-stop"), "{why}"),
        other => panic!("{other:?}"),
    }
    // Released: recovery is explicit and starts with clearing faults, never an old torque.
    rig.feedback([0; 3], 0);
    rig.bus.transmit_pending();
    rig.bus.take_wire();
    rig.arm.enable().expect("released");
    rig.bus.transmit_pending();
    let wire = Rig::decoded(&rig.bus.wire());
    assert_eq!(
        wire,
        vec![
            Message::Control {
                command: ControlCommand::ClearFault,
                node: 0
            },
            Message::Control {
                command: ControlCommand::Enable,
                node: 0
            },
        ]
    );
}

#[test]
fn silent_amplifier_trips_the_watchdog() {
    let mut rig = Rig::new().enabled();
    rig.clock.advance(0.004);
    rig.arm
        .read_joints()
        .expect("4 ms is within the 5 ms limit");
    rig.clock.advance(0.002);
    match rig.arm.read_joints() {
        Err(CanError::Faulted(Fault::FeedbackTimeout {
            joint: 0, age_s, ..
        })) => {
            assert!(age_s > 0.005)
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn watchdog_is_quiet_while_disabled() {
    let mut rig = Rig::new();
    rig.feedback([0; 3], 0);
    rig.arm.read_joints().expect("fresh state");
    rig.clock.advance(1.0);
    let s = rig.arm.read_joints().expect("old state, no fault");
    assert!((drivers::Clock::now_s(&rig.clock) - s.t_s - 1.0).abs() < 1e-9);
    assert_eq!(*rig.arm.state(), DriveState::Disabled);
}

#[test]
fn amplifier_emergency_and_fault_heartbeat() {
    let mut rig = Rig::new().enabled();
    let emcy = Message::Emergency {
        node: 2,
        code: 0x2310,
        error_register: 0x03,
        state: NodeState::Fault,
        detail: [0; 4],
    };
    rig.bus.inject_frame(emcy.encode());
    match rig.arm.read_joints() {
        Err(CanError::Faulted(Fault::Emergency {
            joint: 1,
            code: 0x2310,
            ..
        })) => {}
        other => panic!("{other:?}"),
    }

    let mut rig = Rig::new().enabled();
    let hb = Message::Heartbeat {
        node: 3,
        state: NodeState::Fault,
        error_register: 1,
    };
    rig.bus.inject_frame(hb.encode());
    assert!(matches!(
        rig.arm.read_joints(),
        Err(CanError::Faulted(Fault::Amplifier { joint: 2, .. }))
    ));
}

#[test]
fn non_finite_torque_faults_and_sends_nothing() {
    let mut rig = Rig::new().enabled();
    let r = rig.arm.write_torques(&JointTorques {
        torque_nm: [0.1, f64::NAN, 0.1],
    });
    assert!(matches!(
        r,
        Err(CanError::Faulted(Fault::NonFiniteTorque { joint: 1 }))
    ));
    assert_eq!(Rig::decoded(&rig.bus.pending()), vec![disable_all()]);
}

#[test]
fn a_full_transmit_queue_faults_after_three_cycles() {
    let mut rig = Rig::new().enabled();
    // The bus never transmits: the 64-frame queue fills.
    let mut result = Ok(());
    for _ in 0..30 {
        rig.feedback([0; 3], status::ENABLED);
        let _ = rig.arm.read_joints();
        result = rig.arm.write_torques(&JointTorques {
            torque_nm: [0.1; 3],
        });
        if result.is_err() {
            break;
        }
    }
    assert!(matches!(
        result,
        Err(CanError::Faulted(Fault::TxOverrun { .. }))
    ));
}

#[test]
fn bad_frames_are_counted_and_change_nothing() {
    let mut rig = Rig::new().enabled();
    let junk = [
        DataFrame::new(0x181, &[1, 2, 3]).expect("frame"), // short feedback
        DataFrame::new(0x702, &[7, 0]).expect("frame"),    // undefined state
        DataFrame::new(0x181, &[0, 0, 0, 0, 0, 0, 0xE0, 9]).expect("frame"), // undefined status bits
        DataFrame::new(0x183, &[0, 0, 0, 0]).expect("frame"),
    ];
    for f in junk {
        rig.bus.inject_frame(f);
    }
    rig.bus
        .inject_frame(DataFrame::new(0x555, &[1]).expect("frame")); // not ours
    rig.bus.inject_frame(
        Message::Feedback {
            node: 9,
            counts: 0,
            amp_time_us: 0,
            status: 0,
            seq: 0,
        }
        .encode(),
    ); // a node we do not drive
    rig.bus.inject(BusEvent::Foreign);
    rig.bus.inject(BusEvent::Condition(BusCondition {
        error_warning: true,
        ..BusCondition::default()
    }));
    rig.feedback([0; 3], status::ENABLED);
    rig.arm.read_joints().expect("still running");
    assert_eq!(*rig.arm.state(), DriveState::Enabled);
    let s = rig.arm.stats();
    assert_eq!(s.malformed, 4);
    assert_eq!(s.foreign, 3);
    assert_eq!(s.bus_warnings, 1);
}

#[test]
fn encoder_glitch_is_dropped_and_velocity_follows_the_encoder() {
    let mut rig = Rig::new().enabled();
    let s = JointScaling::for_joints(&CanJoints::default());
    // Joint 1 turns at 2 counts per ms: 2 * 4.6136e-4 rad / 1 ms = 0.9227 rad/s.
    let mut c = 0;
    for _ in 0..50 {
        c += 2;
        rig.feedback([c, 0, 0], status::ENABLED);
        rig.arm.read_joints().expect("state");
    }
    let v = rig.arm.read_joints().expect("state").velocity_rad_s[0];
    assert!((v - 2.0 * s[0].rad_per_count / 0.001).abs() < 1e-6, "{v}");
    // A jump of 100000 counts in 1 ms (46 rad) is not a joint moving.
    rig.feedback([c + 100_000, 0, 0], status::ENABLED);
    let js = rig
        .arm
        .read_joints()
        .expect("glitch dropped, other joints fresh");
    assert!((js.position_rad[0] - f64::from(c) * s[0].rad_per_count).abs() < 1e-12);
    assert_eq!(rig.arm.stats().implausible_feedback, 1);
}

#[test]
fn lost_and_repeated_feedback_is_counted() {
    let mut rig = Rig::new().enabled();
    rig.seq[0] = rig.seq[0].wrapping_add(3); // joint 0 loses two frames
    rig.feedback([0; 3], status::ENABLED);
    rig.arm.read_joints().expect("state");
    let dup = Message::Feedback {
        node: 2,
        counts: 0,
        amp_time_us: rig.amp_us,
        status: status::ENABLED,
        seq: rig.seq[1],
    };
    rig.bus.inject_frame(dup.encode());
    rig.arm.read_joints().expect("state");
    let s = rig.arm.stats();
    assert_eq!((s.feedback_gaps, s.feedback_duplicates), (1, 1));
}

fn any_event() -> impl Strategy<Value = BusEvent> {
    prop_oneof![
        8 => (0u16..=0x7FF, proptest::collection::vec(any::<u8>(), 0..=8))
            .prop_map(|(id, d)| BusEvent::Frame(DataFrame::new(id, &d).expect("valid"))),
        8 => (1u8..=3, any::<i16>(), any::<u8>(), any::<u8>()).prop_map(|(node, c, st, seq)| {
            BusEvent::Frame(Message::Feedback { node, counts: i32::from(c), amp_time_us: u16::from(seq).wrapping_mul(1000), status: st & status::DEFINED, seq }.encode())
        }),
        1 => any::<[bool; 6]>().prop_map(|b| BusEvent::Condition(BusCondition {
            bus_off: b[0], error_passive: b[1], error_warning: b[2], back_to_active: b[3], restarted: b[4], other: b[5],
        })),
        1 => Just(BusEvent::Foreign),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Whatever the bus delivers, nothing panics, every state read is finite, and after a
    /// fatal condition no torque frame is queued until an explicit enable.
    #[test]
    fn arbitrary_bus_traffic(events in proptest::collection::vec(any_event(), 0..200), torque in -1.0f64..1.0) {
        let mut rig = Rig::new().enabled();
        let mut fatal_seen = false;
        for ev in events {
            let fatal = matches!(ev, BusEvent::Condition(c) if c.is_fatal());
            rig.bus.inject(ev);
            rig.clock.advance(0.0005);
            if let Ok(js) = rig.arm.read_joints() {
                prop_assert!(js.is_finite());
            }
            let _ = rig.arm.write_torques(&JointTorques { torque_nm: [torque; 3] });
            fatal_seen |= fatal;
            if fatal_seen {
                prop_assert!(matches!(rig.arm.state(), DriveState::Fault(_)));
                let queued = Rig::decoded(&rig.bus.pending());
                prop_assert!(queued.iter().all(|m| !matches!(m, Message::Torque { .. })), "{:?}", queued);
            }
            rig.bus.transmit_pending();
        }
    }
}

/// What `recover` refused with.
fn not_recovered(r: Result<(), CanError>) -> String {
    match r {
        Err(CanError::NotRecovered(why)) => why,
        other => panic!("expected a refusal naming the cause, got {other:?}"),
    }
}

fn sent_commands(bus: &MockBus) -> Vec<ControlCommand> {
    bus.transmit_pending();
    Rig::decoded(&bus.take_wire())
        .into_iter()
        .filter_map(|m| match m {
            Message::Control { command, .. } => Some(command),
            _ => None,
        })
        .collect()
}

#[test]
fn recover_without_a_fault_changes_nothing() {
    let mut rig = Rig::new();
    rig.feedback([0; 3], 0);
    rig.arm.recover().expect("nothing latched");
    assert_eq!(*rig.arm.state(), DriveState::Disabled);
    assert_eq!(rig.bus.reopens(), 0);
}

#[test]
fn recover_after_an_unplugged_adapter_reopens_it_once_it_is_back() {
    let mut rig = Rig::new().enabled();
    rig.bus.unplug();
    match rig.arm.read_joints() {
        Err(CanError::Faulted(Fault::Adapter { message, .. })) => {
            assert!(message.contains("unplugged"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    // Still unplugged: refused, naming the adapter and the OS's words; enable is too.
    let why = not_recovered(rig.arm.recover());
    assert!(
        why.contains("CAN adapter mock CAN bus not available") && why.contains("unplugged"),
        "{why}"
    );
    assert!(matches!(rig.arm.enable(), Err(CanError::CannotEnable(_))));
    assert_eq!(rig.bus.reopens(), 0);

    // Back, but no amplifier has spoken since: the cause is now the missing feedback.
    rig.bus.replug();
    rig.clock.advance(0.2);
    let why = not_recovered(rig.arm.recover());
    assert!(
        why.contains("no fresh feedback from joint 0 (node 1)"),
        "{why}"
    );
    assert_eq!(rig.bus.reopens(), 1);
    // Feedback again: the latch clears, the arm stays disabled, nothing enables it.
    rig.feedback([5; 3], 0);
    rig.arm.recover().expect("cause gone");
    assert_eq!(*rig.arm.state(), DriveState::Disabled);
    assert_eq!(rig.bus.reopens(), 1, "reopened once, not every call");
    let sent = sent_commands(&rig.bus);
    assert!(!sent.contains(&ControlCommand::Enable), "{sent:?}");
    // And enabling works as on a fresh start.
    rig.arm.enable().expect("enable after recovery");
    rig.feedback([5; 3], status::ENABLED);
    rig.arm.read_joints().expect("enabled");
    assert_eq!(*rig.arm.state(), DriveState::Enabled);
}

#[test]
fn recover_retries_reopening_at_most_every_tenth_of_a_second() {
    let mut rig = Rig::new().enabled();
    rig.bus.unplug();
    let _ = rig.arm.read_joints();
    rig.bus.replug();
    // The first attempt is at once; the loop then calls every millisecond.
    rig.feedback([0; 3], 0);
    let _ = rig.arm.recover();
    assert_eq!(rig.bus.reopens(), 1);
    rig.bus.unplug();
    let _ = rig.arm.read_joints();
    rig.bus.replug();
    for _ in 0..50 {
        rig.clock.advance(0.001);
        let _ = rig.arm.recover();
    }
    assert_eq!(rig.bus.reopens(), 1, "no reopen within 0.1 s of the last");
    rig.clock.advance(0.1);
    let _ = rig.arm.recover();
    assert_eq!(rig.bus.reopens(), 2);
}

#[test]
fn recover_is_refused_while_the_estop_is_open_and_clears_once_released() {
    let mut rig = Rig::new().enabled();
    rig.feedback([0; 3], status::ENABLED | status::ESTOP);
    assert!(rig.arm.read_joints().is_err());
    rig.feedback([0; 3], status::ESTOP);
    let why = not_recovered(rig.arm.recover());
    assert!(
        why.contains("e-stop open on joint 0 (node 1)"),
        "names the cause: {why}"
    );
    assert!(matches!(
        rig.arm.state(),
        DriveState::Fault(Fault::EStop { .. })
    ));
    rig.feedback([0; 3], 0);
    rig.arm.recover().expect("released");
    assert_eq!(*rig.arm.state(), DriveState::Disabled);
    rig.arm.read_joints().expect("joint data again");
    let sent = sent_commands(&rig.bus);
    assert!(!sent.contains(&ControlCommand::Enable), "{sent:?}");
}

#[test]
fn recover_asks_a_faulted_amplifier_to_clear_and_waits_for_it() {
    let mut rig = Rig::new().enabled();
    let emcy = Message::Emergency {
        node: 2,
        code: 0x2310,
        error_register: 0x03,
        state: NodeState::Fault,
        detail: [0; 4],
    };
    rig.bus.inject_frame(emcy.encode());
    assert!(rig.arm.read_joints().is_err());
    sent_commands(&rig.bus);
    // The amplifier still reports its fault: asked to clear it, then refused, naming it.
    let mut st = [0u8; 3];
    st[1] = status::FAULT;
    let feedback_with = |rig: &mut Rig, st: [u8; 3]| {
        rig.clock.advance(0.001);
        for (j, &s) in st.iter().enumerate() {
            rig.seq[j] = rig.seq[j].wrapping_add(1);
            let m = Message::Feedback {
                node: j as u8 + 1,
                counts: 0,
                amp_time_us: 0,
                status: s,
                seq: rig.seq[j],
            };
            rig.bus.inject_frame(m.encode());
        }
    };
    feedback_with(&mut rig, st);
    let why = not_recovered(rig.arm.recover());
    assert!(
        why.contains("joint 1 (node 2) still reports a fault"),
        "{why}"
    );
    assert_eq!(sent_commands(&rig.bus), vec![ControlCommand::ClearFault]);
    // Asked again only after a while, not every call.
    feedback_with(&mut rig, st);
    let _ = rig.arm.recover();
    assert!(sent_commands(&rig.bus).is_empty());
    rig.clock.advance(0.1);
    feedback_with(&mut rig, st);
    let _ = rig.arm.recover();
    assert_eq!(sent_commands(&rig.bus), vec![ControlCommand::ClearFault]);
    // The amplifier cleared: the latch clears, the arm stays disabled.
    feedback_with(&mut rig, [0; 3]);
    rig.arm.recover().expect("amplifier cleared");
    assert_eq!(*rig.arm.state(), DriveState::Disabled);
    assert!(!sent_commands(&rig.bus).contains(&ControlCommand::Enable));
}
