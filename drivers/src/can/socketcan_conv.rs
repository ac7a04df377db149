//! Converting socketcan's frames (from a socket or a candump log) into bus events.

use socketcan::errors::ControllerProblems;
use socketcan::{CanAnyFrame, CanError, EmbeddedFrame, Id};

use super::frame::{BusCondition, BusEvent, DataFrame};

/// The event a socketcan frame stands for.
pub fn event_from_frame(frame: CanAnyFrame) -> BusEvent {
    match frame {
        CanAnyFrame::Normal(f) => match f.id() {
            Id::Standard(id) => DataFrame::new(id.as_raw(), f.data())
                .map(BusEvent::Frame)
                .unwrap_or(BusEvent::Foreign),
            Id::Extended(_) => BusEvent::Foreign,
        },
        CanAnyFrame::Error(e) => BusEvent::Condition(condition_from_error(&e.into_error())),
        CanAnyFrame::Remote(_) | CanAnyFrame::Fd(_) => BusEvent::Foreign,
    }
}

/// The controller conditions a SocketCAN error frame reports.
pub fn condition_from_error(err: &CanError) -> BusCondition {
    let ctrl = err.controller().unwrap_or(ControllerProblems::empty());
    BusCondition {
        bus_off: err.is_bus_off(),
        error_passive: ctrl
            .intersects(ControllerProblems::RX_PASSIVE | ControllerProblems::TX_PASSIVE),
        error_warning: ctrl
            .intersects(ControllerProblems::RX_WARNING | ControllerProblems::TX_WARNING),
        back_to_active: ctrl.contains(ControllerProblems::ACTIVE),
        restarted: err.is_restarted(),
        other: err.is_bus_error()
            || err.is_no_ack()
            || err.is_transmit_timeout()
            || err.lost_arbitration().is_some()
            || err.protocol().is_some()
            || err.transceiver().is_some()
            || ctrl.intersects(ControllerProblems::RX_OVERFLOW | ControllerProblems::TX_OVERFLOW),
    }
}
