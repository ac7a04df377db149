//! The CAN side: arbitrary bytes as slcan text through the line parser, and as a sequence
//! of CAN frames (id, length, data) and bus conditions through the protocol decoder and the
//! driver's state machine on a mock bus. Nothing may panic; decoded messages re-encode to
//! the same frame; every joint state read is finite; after a fatal bus condition no torque
//! frame is queued.
#![no_main]

use std::sync::Arc;

use config::schema::CanJoints;
use control::ports::Manipulator;
use control::types::JointTorques;
use drivers::ManualClock;
use drivers::can::protocol::Message;
use drivers::can::slcan::{Item, LineParser};
use drivers::can::{BusCondition, BusEvent, DataFrame, DriveState, MockBus, PhantomCan};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut lines = LineParser::default();
    lines.push(data, |item| {
        if let Item::Frame(f) = item {
            assert!(f.id() <= 0x7FF && f.data().len() <= 8);
        }
    });

    let bus = MockBus::new(32);
    let clock = ManualClock::new(1.0);
    let mut arm = PhantomCan::new(bus.clone(), &CanJoints::default(), Arc::new(clock.clone()));
    let mut fatal = false;
    let mut rest = data;
    while let [tag, id_lo, id_hi, tail @ ..] = rest {
        let len = usize::from(tag & 0x0F).min(tail.len());
        let (payload, next) = tail.split_at(len);
        rest = next;
        let event = match tag >> 4 {
            0xF => {
                let b = id_lo;
                let c = BusCondition {
                    bus_off: b & 1 != 0,
                    error_passive: b & 2 != 0,
                    error_warning: b & 4 != 0,
                    back_to_active: b & 8 != 0,
                    restarted: b & 16 != 0,
                    other: b & 32 != 0,
                };
                fatal |= c.is_fatal();
                BusEvent::Condition(c)
            }
            0xE => BusEvent::Foreign,
            _ => {
                let id = u16::from_le_bytes([*id_lo, *id_hi]) & 0x7FF;
                let Some(f) = DataFrame::new(id, &payload[..payload.len().min(8)]) else {
                    continue;
                };
                if let Ok(Some(m)) = Message::decode(&f) {
                    assert_eq!(m.encode(), f);
                }
                BusEvent::Frame(f)
            }
        };
        bus.inject(event);
        clock.advance(0.0004);
        match tag & 0x30 {
            0x10 => {
                let _ = arm.enable();
            }
            0x20 => {
                let _ = arm.disable();
            }
            _ => {}
        }
        if let Ok(js) = arm.read_joints() {
            assert!(js.is_finite());
        }
        let t = f64::from(i16::from_le_bytes([*id_lo, *id_hi])) * 1e-3;
        let _ = arm.write_torques(&JointTorques {
            torque_nm: [t, -t, t],
        });
        if fatal && matches!(arm.state(), DriveState::Fault(_)) {
            let queued: Vec<_> = bus
                .pending()
                .iter()
                .filter_map(|f| Message::decode(f).ok().flatten())
                .collect();
            assert!(!queued.iter().any(|m| matches!(m, Message::Torque { .. })));
        }
        if tag & 0x40 != 0 {
            bus.transmit_pending();
        }
        if tag & 0x30 == 0x10 {
            fatal = false; // an enable was attempted: torques may follow legitimately
        }
    }
});
