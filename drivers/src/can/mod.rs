//! The Phantom's joint amplifiers on CAN: protocol (docs/protocols/phantom-can.md), the
//! driver, and adapters (SocketCAN, slcan over a tty, a mock, candump replay).

pub mod adapter;
pub mod driver;
pub mod frame;
pub mod mock;
pub mod phantom_emulator;
pub mod protocol;
pub mod replay;
pub mod scaling;
pub mod slcan;
pub mod socketcan_adapter;
mod socketcan_conv;

pub use adapter::{AdapterError, CanAdapter};
pub use driver::{CanError, CanStats, DriveState, Fault, PhantomCan};
pub use frame::{BusCondition, BusEvent, DataFrame};
pub use mock::MockBus;
