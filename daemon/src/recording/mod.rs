//! Trial recording: MCAP files (zstd chunks, JSON-schema channels, Unix-epoch times, the
//! resolved config and build in metadata) plus a JSON summary per trial,
//! written by one thread with a documented flush and fsync policy (docs/daemon.md).

pub mod foxglove_msgs;
pub mod messages;
pub mod naming;
pub mod provenance;
pub mod recorder;
pub mod recover;
pub mod replay;
pub mod space;
pub mod startup;
pub mod topics;
pub mod trial_file;
