//! The 1 kHz control loop on its own thread: the cycle, its safety layer, the flight
//! recorder, timing, and the link to the rest of the daemon.

pub mod control_loop;
pub mod core_servo;
pub mod fault;
pub mod flight_recorder;
pub mod link;
pub mod os;
pub mod period_stats;
pub mod safety;
pub mod servo;
pub mod thread;
