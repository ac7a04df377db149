//! The pure core of pulsetrack.
//!
//! Everything here is a step function over plain data: no I/O, no async runtime, no clock of
//! its own (time always arrives as an argument), and no allocation in the per-cycle path.
//! Hardware drivers and the simulator implement the [`ports`]; the daemon wires them to the
//! controllers and trackers defined here, so the same code runs on the rig and in the sim.
//!
//! Units are SI throughout (m, s, N, Pa, rad). Frames are described in [`frames`].

pub mod calibration;
pub mod classify;
pub mod frames;
pub mod kinematics;
pub mod motion;
pub mod pd;
pub mod ports;
pub mod search;
pub mod sensor;
pub mod signal;
pub mod staleness;
#[cfg(test)]
mod test_heart;
#[cfg(test)]
mod test_normals;
pub mod tracker;
pub mod types;
