//! Trial recording: MCAP files with JSON-schema channels plus a JSON summary per trial,
//! written by one thread with a documented flush and fsync policy (docs/daemon.md).

pub mod naming;
pub mod recorder;
pub mod recover;
pub mod space;
pub mod startup;
pub mod topics;
pub mod trial_file;
