//! Hardware drivers implementing control's ports: the tactile array over a serial line and
//! the Phantom's joint amplifiers over CAN, plus emulators of both devices that speak the
//! same protocols on pseudo-terminals, so the real drivers run end to end without hardware.
//!
//! Nothing here panics on input from outside: every malformed byte, frame or value is
//! counted, logged once per burst and survived.

pub mod burst_log;
pub mod can;
pub mod clock;
pub mod hardware;
pub mod programs;
pub mod pty;
pub mod tactile;

pub use clock::{Clock, ManualClock, MonotonicClock};
