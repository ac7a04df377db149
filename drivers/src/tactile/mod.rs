//! The tactile array over a serial line: protocol (docs/protocols/tactile-serial.md),
//! driver and emulator.

pub mod cobs;
pub mod crc;
pub mod decoder;
pub mod emulator;
mod link;
pub mod port;
pub mod pulse;
pub mod status;
pub mod stream_check;
pub mod wire;

pub use port::{SerialTactileArray, TactileError};
pub use status::{LinkState, LinkStatus, TactileStats};
